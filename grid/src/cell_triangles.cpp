// Triangles within each cell's reach (cell_triangles.h).
#include "soda/grid/cell_triangles.h"

#include <algorithm>
#include <array>

namespace soda {
namespace {

// Adds 1 to every box cell whose grown box overlaps the triangle a, b, c.
struct TriangleCounter {
  const UniformGrid& grid;
  const CellBox& box;
  std::vector<std::int32_t>& counts;
  double grow;  // half a cell

  void add(const Vec3& a, const Vec3& b, const Vec3& c) const {
    const Vec3 lo = a.cwiseMin(b).cwiseMin(c) - Vec3::Constant(grow);
    const Vec3 hi = a.cwiseMax(b).cwiseMax(c) + Vec3::Constant(grow);
    const CellBox cells = grid.cells_overlapping(lo, hi);
    CellBox in;
    for (int axis = 0; axis < 3; ++axis) {
      in.lo[axis] = std::max(cells.lo[axis], box.lo[axis]);
      in.hi[axis] = std::min(cells.hi[axis], box.hi[axis]);
    }
    if (!in.valid()) return;
    for (int x = in.lo.x; x <= in.hi.x; ++x)
      for (int y = in.lo.y; y <= in.hi.y; ++y)
        for (int z = in.lo.z; z <= in.hi.z; ++z) ++counts[box.index({x, y, z})];
  }
};

Vec3 to_world(const Body& body, const Quat& q, const Vec3& local) { return body.position + q * local; }

void add_mesh(const Body& body, const TriangleCounter& counter) {
  const TriangleMeshData& mesh = *body.shape.mesh;
  const Quat q = body.orientation.normalized();
  std::vector<Vec3> world;
  world.reserve(mesh.vertices.size());
  for (const Vec3& v : mesh.vertices) world.push_back(to_world(body, q, v));
  for (const auto& t : mesh.triangles) counter.add(world[t[0]], world[t[1]], world[t[2]]);
}

// Sample (i, j) at x = (i - (columns - 1) / 2) * spacing.x, y = height *
// spacing.y, z = (j - (rows - 1) / 2) * spacing.z; each quad split along
// the diagonal from (i + 1, j) to (i, j + 1), as Bullet splits it
// (docs/scene-format.md).
void add_heightfield(const Body& body, const TriangleCounter& counter) {
  const HeightfieldData& hf = *body.shape.heightfield;
  const Quat q = body.orientation.normalized();
  const auto columns = static_cast<std::size_t>(hf.columns), rows = static_cast<std::size_t>(hf.rows);
  std::vector<Vec3> world;
  world.reserve(columns * rows);
  for (std::size_t j = 0; j < rows; ++j)
    for (std::size_t i = 0; i < columns; ++i) {
      const Vec3 local((static_cast<double>(i) - static_cast<double>(columns - 1) / 2.0) * hf.spacing.x(),
                       hf.heights[j * columns + i] * hf.spacing.y(),
                       (static_cast<double>(j) - static_cast<double>(rows - 1) / 2.0) * hf.spacing.z());
      world.push_back(to_world(body, q, local));
    }
  for (std::size_t j = 0; j + 1 < rows; ++j)
    for (std::size_t i = 0; i + 1 < columns; ++i) {
      const Vec3& p00 = world[j * columns + i];
      const Vec3& p10 = world[j * columns + i + 1];
      const Vec3& p01 = world[(j + 1) * columns + i];
      const Vec3& p11 = world[(j + 1) * columns + i + 1];
      counter.add(p00, p10, p01);
      counter.add(p10, p11, p01);
    }
}

}  // namespace

bool has_level_geometry(const std::vector<Body>& bodies) {
  return std::any_of(bodies.begin(), bodies.end(), [](const Body& b) {
    return b.is_static && ((b.shape.kind == ShapeKind::TriangleMesh && b.shape.mesh) ||
                           (b.shape.kind == ShapeKind::Heightfield && b.shape.heightfield));
  });
}

std::vector<std::int32_t> cell_triangles(const std::vector<Body>& bodies, const UniformGrid& grid,
                                         const CellBox& box) {
  std::vector<std::int32_t> counts(static_cast<std::size_t>(box.count()), 0);
  const TriangleCounter counter{grid, box, counts, grid.cell_size() / 2.0};
  for (const Body& b : bodies) {
    if (!b.is_static) continue;
    if (b.shape.kind == ShapeKind::TriangleMesh && b.shape.mesh) add_mesh(b, counter);
    if (b.shape.kind == ShapeKind::Heightfield && b.shape.heightfield) add_heightfield(b, counter);
  }
  return counts;
}

}  // namespace soda
