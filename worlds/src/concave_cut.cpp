// The part of a static mesh or heightfield near a rank's worlds
// (concave_cut.h).
#include "concave_cut.h"

#include <algorithm>
#include <limits>
#include <memory>

namespace soda {
namespace {

struct Placement {
  Eigen::Matrix3d rotation;
  Vec3 position;
  bool turned;
  Vec3 at(const Vec3& local) const { return rotation * local + position; }
};

Placement placement_of(const Body& b) {
  const Quat q = b.orientation.normalized();
  return {q.toRotationMatrix(), b.position, !q.isApprox(Quat::Identity(), 0.0)};
}

Shape cut_mesh(const Body& body, const NearKeptWorlds& near) {
  const TriangleMeshData& m = *body.shape.mesh;
  const Placement p = placement_of(body);
  auto cut = std::make_shared<MeshCut>();
  cut->lo = Vec3::Constant(std::numeric_limits<double>::infinity());
  cut->hi = -cut->lo;
  std::vector<Vec3> at;
  at.reserve(m.vertices.size());
  for (const Vec3& v : m.vertices) {
    cut->lo = cut->lo.cwiseMin(v), cut->hi = cut->hi.cwiseMax(v);
    cut->radius = std::max(cut->radius, v.norm());
    at.push_back(p.at(v));
  }
  for (std::size_t t = 0; t < m.triangles.size(); ++t) {
    const auto& tri = m.triangles[t];
    const Vec3 lo = at[tri[0]].cwiseMin(at[tri[1]]).cwiseMin(at[tri[2]]);
    const Vec3 hi = at[tri[0]].cwiseMax(at[tri[1]]).cwiseMax(at[tri[2]]);
    if (near(lo, hi, p.turned)) cut->whole_index.push_back(static_cast<std::uint32_t>(t));
  }
  if (cut->whole_index.size() == m.triangles.size()) return body.shape;
  if (cut->whole_index.empty()) cut->whole_index.push_back(0);  // Bullet's tree needs a triangle
  // The vertices the part's triangles use, in the whole's order.
  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> index(m.vertices.size(), kUnused);
  for (std::uint32_t t : cut->whole_index)
    for (std::uint32_t v : m.triangles[t]) index[v] = 0;
  auto part = std::make_shared<TriangleMeshData>();
  part->file = m.file;
  for (std::size_t v = 0; v < index.size(); ++v)
    if (index[v] != kUnused) {
      index[v] = static_cast<std::uint32_t>(part->vertices.size());
      part->vertices.push_back(m.vertices[v]);
    }
  part->triangles.reserve(cut->whole_index.size());
  for (std::uint32_t t : cut->whole_index) {
    const auto& tri = m.triangles[t];
    part->triangles.push_back({index[tri[0]], index[tri[1]], index[tri[2]]});
  }
  part->cut = std::move(cut);
  return Shape::triangle_mesh(std::move(part));
}

Shape cut_heightfield(const Body& body, const NearKeptWorlds& near) {
  const HeightfieldData& h = *body.shape.heightfield;
  const Placement p = placement_of(body);
  const auto local = [&](int i, int j) {
    return Vec3((i - 0.5 * (h.columns - 1)) * h.spacing.x(), h.height(i, j) * h.spacing.y(),
                (j - 0.5 * (h.rows - 1)) * h.spacing.z());
  };
  // The window: the samples of every quad whose box `near` accepts.
  int c0 = h.columns, c1 = -1, r0 = h.rows, r1 = -1;
  for (int j = 0; j + 1 < h.rows; ++j)
    for (int i = 0; i + 1 < h.columns; ++i) {
      Vec3 lo = p.at(local(i, j)), hi = lo;
      for (const Vec3& c : {p.at(local(i + 1, j)), p.at(local(i, j + 1)), p.at(local(i + 1, j + 1))})
        lo = lo.cwiseMin(c), hi = hi.cwiseMax(c);
      if (!near(lo, hi, p.turned)) continue;
      c0 = std::min(c0, i), c1 = std::max(c1, i + 1), r0 = std::min(r0, j), r1 = std::max(r1, j + 1);
    }
  if (c1 < 0) c0 = 0, c1 = 1, r0 = 0, r1 = 1;  // Bullet's shape needs a quad
  // Bullet visits a quad beyond the box on each side (and rejects it).
  c0 = std::max(c0 - 1, 0), r0 = std::max(r0 - 1, 0);
  c1 = std::min(c1 + 1, h.columns - 1), r1 = std::min(r1 + 1, h.rows - 1);
  if (c0 == 0 && r0 == 0 && c1 == h.columns - 1 && r1 == h.rows - 1) return body.shape;
  auto part = std::make_shared<HeightfieldData>();
  part->columns = h.columns;
  part->rows = h.rows;
  part->spacing = h.spacing;
  part->window = {c0, r0, c1 - c0 + 1, r1 - r0 + 1, h.max_abs_raw_height()};
  part->heights.reserve(static_cast<std::size_t>(part->window.columns) * part->window.rows);
  for (int j = r0; j <= r1; ++j)
    for (int i = c0; i <= c1; ++i) part->heights.push_back(h.height(i, j));
  return Shape::heightfield_of(std::move(part));
}

}  // namespace

Shape cut_concave_shape(const Body& body, const NearKeptWorlds& near) {
  const Shape& s = body.shape;
  if (s.kind == ShapeKind::TriangleMesh && s.mesh && !s.mesh->cut) return cut_mesh(body, near);
  if (s.kind == ShapeKind::Heightfield && s.heightfield && s.heightfield->window.columns == 0)
    return cut_heightfield(body, near);
  return body.shape;
}

}  // namespace soda
