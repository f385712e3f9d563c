// The scene header chunk (docs/replay-format.md, "HEAD").
#include <cmath>
#include <string>

#include "byte_io.h"
#include "replay_codec.h"

namespace soda::replay {
namespace {

constexpr std::size_t kMaxNameBytes = 4096;
constexpr std::uint32_t kMaxHullPoints = 1u << 20;

void put_vec(ByteWriter& w, const Vec3& v) {
  for (int a = 0; a < 3; ++a) w.f64(v[a]);
}
Vec3 get_vec(ByteReader& r) {
  Vec3 v;
  for (int a = 0; a < 3; ++a) v[a] = r.f64();
  return v;
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

// One body's record, the same in HEAD and BODS.
// A compound, a triangle mesh or a heightfield is recorded as the box of
// its local AABB (the replay format draws convex shapes only).
void put_body(ByteWriter& w, const ViewBody& b) {
  w.u32(b.id);
  w.u8(b.is_static ? 1 : 0);
  const bool compound = b.shape.kind == ShapeKind::Compound || b.shape.is_concave();
  w.u8(static_cast<std::uint8_t>(compound ? ShapeKind::Box : b.shape.kind));
  put_vec(w, compound ? b.shape.local_half_extents() : b.shape.half_extents);
  w.f64(b.shape.radius);
  w.f64(b.shape.height);
  w.u32(static_cast<std::uint32_t>(b.shape.points.size()));
  for (const Vec3& p : b.shape.points) put_vec(w, p);
  put_vec(w, b.position);
  w.f64(b.orientation.x());
  w.f64(b.orientation.y());
  w.f64(b.orientation.z());
  w.f64(b.orientation.w());
}

ViewBody get_body(ByteReader& r) {
  ViewBody b;
  b.id = r.u32();
  b.is_static = r.u8() != 0;
  const std::uint8_t kind = r.u8();
  if (kind > static_cast<std::uint8_t>(ShapeKind::ConvexHull))
    r.fail("body " + std::to_string(b.id) + ": shape kind " + std::to_string(kind));
  b.shape.kind = static_cast<ShapeKind>(kind);
  b.shape.half_extents = get_vec(r);
  b.shape.radius = r.f64();
  b.shape.height = r.f64();
  const std::uint32_t points = r.u32();
  if (points > kMaxHullPoints) r.fail("body " + std::to_string(b.id) + ": " + std::to_string(points) + " hull points");
  b.shape.points.resize(r.count(points, 24, "hull points"));
  for (Vec3& p : b.shape.points) p = get_vec(r);
  b.position = get_vec(r);
  const double x = r.f64(), y = r.f64(), z = r.f64(), qw = r.f64();
  b.orientation = Quat(qw, x, y, z);
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

ViewHeader decode_header(std::span<const std::uint8_t> raw, std::uint32_t& keyframe_every) {
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
    h.bodies[i] = get_body(r);
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

std::vector<ViewBody> decode_bodies(std::span<const std::uint8_t> raw) {
  ByteReader r(raw, "added bodies");
  std::vector<ViewBody> out(r.count(r.u32(), 1, "bodies"));
  for (std::size_t i = 0; i < out.size(); ++i) {
    out[i] = get_body(r);
    if (out[i].is_static) r.fail("body " + std::to_string(out[i].id) + " is static (only dynamic bodies are added)");
    if (i > 0 && out[i].id <= out[i - 1].id) r.fail("body ids not ascending at body #" + std::to_string(i));
  }
  if (r.remaining() != 0) r.fail(std::to_string(r.remaining()) + " bytes left over");
  return out;
}

}  // namespace soda::replay
