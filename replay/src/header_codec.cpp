// The scene header chunk (docs/replay-format.md, "HEAD").
#include <cmath>
#include <memory>
#include <string>

#include "byte_io.h"
#include "replay_codec.h"

namespace soda::replay {
namespace {

constexpr std::size_t kMaxNameBytes = 4096;
constexpr std::uint32_t kMaxHullPoints = 1u << 20;
// A compound child's least bytes: kind, dimensions, counts, pose.
constexpr std::size_t kMinChildBytes = 1 + 8 * 5 + 4 + 4 + 8 * 7;

void put_vec(ByteWriter& w, const Vec3& v) {
  for (int a = 0; a < 3; ++a) w.f64(v[a]);
}
Vec3 get_vec(ByteReader& r) {
  Vec3 v;
  for (int a = 0; a < 3; ++a) v[a] = r.f64();
  return v;
}
// x, y, z, w.
void put_quat(ByteWriter& w, const Quat& q) {
  w.f64(q.x());
  w.f64(q.y());
  w.f64(q.z());
  w.f64(q.w());
}
Quat get_quat(ByteReader& r) {
  const double x = r.f64(), y = r.f64(), z = r.f64(), qw = r.f64();
  return Quat(qw, x, y, z);
}
void put_cell(ByteWriter& w, const CellCoord& c) {
  w.i32(c.x);
  w.i32(c.y);
  w.i32(c.z);
}
CellCoord get_cell(ByteReader& r) {
  CellCoord c;
  c.x = r.i32();
  c.y = r.i32();
  c.z = r.i32();
  return c;
}

// A shape: kind, dimensions, hull points; from version 3 also a compound's
// children (each a shape and a pose) and a mesh's or heightfield's data. A
// version 2 file holds a compound, mesh or heightfield as the box of its
// local AABB.
void put_shape(ByteWriter& w, const Shape& s) {
  w.u8(static_cast<std::uint8_t>(s.kind));
  put_vec(w, s.half_extents);
  w.f64(s.radius);
  w.f64(s.height);
  w.u32(static_cast<std::uint32_t>(s.points.size()));
  for (const Vec3& p : s.points) put_vec(w, p);
  w.u32(static_cast<std::uint32_t>(s.children.size()));
  for (const CompoundChild& c : s.children) {
    put_shape(w, c.shape);
    put_vec(w, c.position);
    put_quat(w, c.orientation);
  }
  if (s.kind == ShapeKind::TriangleMesh) {
    w.string(s.mesh->file);
    w.u32(static_cast<std::uint32_t>(s.mesh->vertices.size()));
    for (const Vec3& v : s.mesh->vertices) put_vec(w, v);
    w.u32(static_cast<std::uint32_t>(s.mesh->triangles.size()));
    for (const auto& t : s.mesh->triangles) w.u32(t[0]), w.u32(t[1]), w.u32(t[2]);
  } else if (s.kind == ShapeKind::Heightfield) {
    w.i32(s.heightfield->columns);
    w.i32(s.heightfield->rows);
    put_vec(w, s.heightfield->spacing);
    for (double h : s.heightfield->heights) w.f64(h);
  }
}

// A shape of a file of `version`; `child`: a compound's child (convex only).
// Version 1 and 2 files hold convex kinds only and end a shape after its
// hull points. Names `body` in errors.
Shape get_shape(ByteReader& r, BodyId body, bool child, std::uint32_t version) {
  const std::string who = "body " + std::to_string(body) + (child ? ": a compound child" : "");
  Shape s;
  const std::uint8_t kind = r.u8();
  const auto last = child || version < 3 ? ShapeKind::ConvexHull : ShapeKind::Heightfield;
  if (kind > static_cast<std::uint8_t>(last)) r.fail(who + ": shape kind " + std::to_string(kind));
  s.kind = static_cast<ShapeKind>(kind);
  s.half_extents = get_vec(r);
  s.radius = r.f64();
  s.height = r.f64();
  const std::uint32_t points = r.u32();
  if (points > kMaxHullPoints) r.fail(who + ": " + std::to_string(points) + " hull points");
  s.points.resize(r.count(points, 24, "hull points"));
  for (Vec3& p : s.points) p = get_vec(r);
  if (version < 3) return s;
  const std::size_t children = r.count(r.u32(), kMinChildBytes, "compound children");
  if (children > 0 && s.kind != ShapeKind::Compound) r.fail(who + ": children on a " + shape_kind_name(s.kind));
  if (children == 0 && s.kind == ShapeKind::Compound) r.fail(who + ": a compound without children");
  for (std::size_t i = 0; i < children; ++i) {
    CompoundChild c;
    c.shape = get_shape(r, body, true, version);
    c.position = get_vec(r);
    c.orientation = get_quat(r);
    s.children.push_back(std::move(c));
  }
  if (s.kind == ShapeKind::TriangleMesh) {
    auto mesh = std::make_shared<TriangleMeshData>();
    mesh->file = r.string(kMaxNameBytes);
    mesh->vertices.resize(r.count(r.u32(), 24, "mesh vertices"));
    for (Vec3& v : mesh->vertices) v = get_vec(r);
    mesh->triangles.resize(r.count(r.u32(), 12, "mesh triangles"));
    for (auto& t : mesh->triangles)
      for (std::uint32_t& i : t)
        if ((i = r.u32()) >= mesh->vertices.size())
          r.fail(who + ": a triangle names vertex " + std::to_string(i) + " of " +
                 std::to_string(mesh->vertices.size()));
    if (mesh->triangles.empty()) r.fail(who + ": a triangle mesh without triangles");
    s.mesh = std::move(mesh);
  } else if (s.kind == ShapeKind::Heightfield) {
    auto field = std::make_shared<HeightfieldData>();
    field->columns = r.i32();
    field->rows = r.i32();
    if (field->columns < 2 || field->rows < 2)
      r.fail(who + ": a heightfield of " + std::to_string(field->columns) + " x " + std::to_string(field->rows) +
             " samples");
    field->spacing = get_vec(r);
    const std::uint64_t samples = std::uint64_t(field->columns) * std::uint64_t(field->rows);
    field->heights.resize(r.count(samples, 8, "heightfield samples"));
    for (double& h : field->heights) h = r.f64();
    s.heightfield = std::move(field);
  }
  return s;
}

// One body's record, the same in HEAD and BODS.
void put_body(ByteWriter& w, const ViewBody& b) {
  w.u32(b.id);
  w.u8(b.is_static ? 1 : 0);
  put_shape(w, b.shape);
  put_vec(w, b.position);
  put_quat(w, b.orientation);
}

ViewBody get_body(ByteReader& r, std::uint32_t version) {
  ViewBody b;
  b.id = r.u32();
  b.is_static = r.u8() != 0;
  b.shape = get_shape(r, b.id, false, version);
  if (b.shape.is_concave() && !b.is_static)
    r.fail("body " + std::to_string(b.id) + ": a dynamic " + shape_kind_name(b.shape.kind));
  b.position = get_vec(r);
  b.orientation = get_quat(r);
  return b;
}

}  // namespace

FrameShape frame_shape(const ViewHeader& header) {
  FrameShape s;
  s.bodies = header.dynamic_count();
  s.worlds = header.territories;
  s.cells = header.box.valid() ? static_cast<std::size_t>(header.box.count()) : 0;
  return s;
}

std::vector<std::uint8_t> encode_header(const ViewHeader& h, std::uint32_t keyframe_every) {
  ByteWriter w;
  w.u32(keyframe_every);
  w.string(h.scene);
  w.u64(h.seed);
  w.f64(h.dt);
  w.i32(h.territories);
  put_vec(w, h.grid.origin());
  w.f64(h.grid.cell_size());
  put_cell(w, h.box.lo);
  put_cell(w, h.box.hi);
  w.u32(static_cast<std::uint32_t>(h.bodies.size()));
  for (const ViewBody& b : h.bodies) put_body(w, b);
  return std::move(w.bytes());
}

ViewHeader decode_header(std::span<const std::uint8_t> raw, std::uint32_t version, std::uint32_t& keyframe_every) {
  ByteReader r(raw, "scene header");
  ViewHeader h;
  keyframe_every = r.u32();
  if (keyframe_every < 1) r.fail("keyframe interval 0");
  h.scene = r.string(kMaxNameBytes);
  h.seed = r.u64();
  h.dt = r.f64();
  if (!(std::isfinite(h.dt) && h.dt > 0)) r.fail("dt " + std::to_string(h.dt) + " is not a positive number");
  h.territories = r.i32();
  if (h.territories < 1 || h.territories > 0xFFFF) r.fail("territories " + std::to_string(h.territories));
  const Vec3 origin = get_vec(r);
  const double cell_size = r.f64();
  try {
    h.grid = UniformGrid(origin, cell_size);
  } catch (const std::exception& e) {
    r.fail(std::string("grid: ") + e.what());
  }
  h.box.lo = get_cell(r);
  h.box.hi = get_cell(r);
  if (h.box.valid() && h.box.count() > kMaxBoxCells) r.fail("box of " + std::to_string(h.box.count()) + " cells");
  const std::size_t n = r.count(r.u32(), 1, "bodies");
  h.bodies.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    h.bodies[i] = get_body(r, version);
    if (i > 0 && h.bodies[i].id <= h.bodies[i - 1].id) r.fail("body ids not ascending at body #" + std::to_string(i));
  }
  if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " bytes left over");
  return h;
}

std::vector<std::uint8_t> encode_bodies(const std::vector<ViewBody>& bodies) {
  ByteWriter w;
  w.u32(static_cast<std::uint32_t>(bodies.size()));
  for (const ViewBody& b : bodies) put_body(w, b);
  return std::move(w.bytes());
}

std::vector<ViewBody> decode_bodies(std::span<const std::uint8_t> raw, std::uint32_t version) {
  ByteReader r(raw, "added bodies");
  std::vector<ViewBody> out(r.count(r.u32(), 1, "bodies"));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = get_body(r, version);
    if (out[i].is_static) r.fail("body " + std::to_string(out[i].id) + " is static (only dynamic bodies are added)");
    if (i > 0 && out[i].id <= out[i - 1].id) r.fail("body ids not ascending at body #" + std::to_string(i));
  }
  if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " bytes left over");
  return out;
}

}  // namespace soda::replay
