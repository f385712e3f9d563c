#include "soda/viewer/frame_codec.h"

#include <bit>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include "soda/scene/hash_text.h"

namespace soda::viewer {
namespace {

static_assert(std::endian::native == std::endian::little, "the binary frame is written little-endian as in memory");

nlohmann::json vec(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

nlohmann::json shape_json(const Shape& s) {
  nlohmann::json j = {{"kind", shape_kind_name(s.kind)}};
  switch (s.kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder: j["half_extents"] = vec(s.half_extents); break;
    case ShapeKind::Sphere: j["radius"] = s.radius; break;
    case ShapeKind::Capsule:
      j["radius"] = s.radius;
      j["height"] = s.height;
      break;
    case ShapeKind::ConvexHull: {
      nlohmann::json pts = nlohmann::json::array();
      for (const Vec3& p : s.points) pts.push_back(vec(p));
      j["points"] = std::move(pts);
      break;
    }
    case ShapeKind::Compound: {
      // Drawn as the box of its local AABB; the children follow for a
      // viewer that draws them.
      j["half_extents"] = vec(s.local_half_extents());
      nlohmann::json kids = nlohmann::json::array();
      for (const CompoundChild& c : s.children)
        kids.push_back({{"shape", shape_json(c.shape)},
                        {"position", vec(c.position)},
                        {"orientation", {c.orientation.x(), c.orientation.y(), c.orientation.z(), c.orientation.w()}}});
      j["children"] = std::move(kids);
      break;
    }
    case ShapeKind::TriangleMesh: {
      // Flat arrays: x, y, z per vertex; a, b, c per triangle.
      nlohmann::json vertices = nlohmann::json::array(), indices = nlohmann::json::array();
      if (s.mesh) {
        for (const Vec3& v : s.mesh->vertices) vertices.push_back(v.x()), vertices.push_back(v.y()), vertices.push_back(v.z());
        for (const auto& t : s.mesh->triangles) indices.push_back(t[0]), indices.push_back(t[1]), indices.push_back(t[2]);
      }
      j["vertices"] = std::move(vertices);
      j["indices"] = std::move(indices);
      break;
    }
    case ShapeKind::Heightfield:
      if (s.heightfield) {
        j["columns"] = s.heightfield->columns;
        j["rows"] = s.heightfield->rows;
        j["spacing"] = vec(s.heightfield->spacing);
        j["heights"] = s.heightfield->heights;
      }
      break;
  }
  return j;
}

nlohmann::json cell(const CellCoord& c) { return {c.x, c.y, c.z}; }

template <class T>
void append(std::string& out, const T* data, std::size_t count) {
  out.append(reinterpret_cast<const char*>(data), count * sizeof(T));
}

template <class T>
void append_value(std::string& out, T value) {
  append(out, &value, 1);
}

}  // namespace

nlohmann::json body_json(const replay::ViewBody& b) {
  return {{"id", b.id},
          {"static", b.is_static},
          {"shape", shape_json(b.shape)},
          {"position", vec(b.position)},
          {"orientation", {b.orientation.x(), b.orientation.y(), b.orientation.z(), b.orientation.w()}}};
}

nlohmann::json header_json(const replay::ViewHeader& h) {
  nlohmann::json bodies = nlohmann::json::array();
  for (const replay::ViewBody& b : h.bodies) bodies.push_back(body_json(b));
  return {{"format", "soda-view-header"},
          {"version", 1},
          {"scene", h.scene},
          {"seed", std::to_string(h.seed)},
          {"dt", h.dt},
          {"territories", h.territories},
          {"dynamic_count", h.dynamic_count()},
          {"grid", {{"origin", vec(h.grid.origin())}, {"cell_size", h.grid.cell_size()}}},
          {"box", {{"lo", cell(h.box.lo)}, {"hi", cell(h.box.hi)}}},
          {"bodies", std::move(bodies)}};
}

nlohmann::json frame_json(const replay::ViewFrame& f, bool finished) {
  return {{"step", f.step},
          {"ids", f.ids ? nlohmann::json(*f.ids) : nlohmann::json(nullptr)},
          {"position", f.position},
          {"orientation", f.orientation},
          {"sleeping", f.sleeping},
          {"owner", f.owner},
          {"cell_owner", f.cell_owner},
          {"world_busy_ms", f.world_busy_ms},
          {"state_hash", f.state_hash ? nlohmann::json(hash_hex(*f.state_hash)) : nlohmann::json(nullptr)},
          {"finished", finished}};
}

std::string frame_binary(const replay::ViewFrame& f, bool finished) {
  const std::size_t n = f.owner.size();
  if (f.position.size() != 3 * n || f.orientation.size() != 4 * n || f.sleeping.size() != n)
    throw std::invalid_argument("frame " + std::to_string(f.step) + ": per-body arrays disagree (" +
                                std::to_string(f.position.size()) + " position floats, " +
                                std::to_string(f.orientation.size()) + " orientation floats, " +
                                std::to_string(f.sleeping.size()) + " sleep flags, " + std::to_string(n) + " owners)");
  if (f.ids && f.ids->size() != n)
    throw std::invalid_argument("frame " + std::to_string(f.step) + ": " + std::to_string(f.ids->size()) +
                                " ids for " + std::to_string(n) + " bodies");
  std::string out;
  out.reserve(kFrameHeaderBytes + n * ((f.ids ? 4 : 0) + 7 * 4 + 2 + 1) + f.cell_owner.size() * 2 +
              f.world_busy_ms.size() * 4);
  // Offsets: 0 magic, 4 flags, 8 step, 16 n, 20 b, 24 c, 28 reserved, 32 hash.
  out.append(kFrameMagic, 4);
  append_value<std::uint32_t>(out, (f.state_hash ? kFrameHasHash : 0u) | (finished ? kFrameFinished : 0u) |
                                       (f.ids ? kFrameHasIds : 0u));
  append_value<std::int64_t>(out, f.step);
  append_value<std::uint32_t>(out, static_cast<std::uint32_t>(n));
  append_value<std::uint32_t>(out, static_cast<std::uint32_t>(f.world_busy_ms.size()));
  append_value<std::uint32_t>(out, static_cast<std::uint32_t>(f.cell_owner.size()));
  append_value<std::uint32_t>(out, 0);
  append_value<std::uint64_t>(out, f.state_hash.value_or(0));
  if (out.size() != kFrameHeaderBytes) throw std::logic_error("frame_binary: header size");
  if (f.ids) append(out, f.ids->data(), f.ids->size());
  append(out, f.position.data(), f.position.size());
  append(out, f.orientation.data(), f.orientation.size());
  append(out, f.world_busy_ms.data(), f.world_busy_ms.size());
  append(out, f.owner.data(), f.owner.size());
  append(out, f.cell_owner.data(), f.cell_owner.size());
  append(out, f.sleeping.data(), f.sleeping.size());
  return out;
}

}  // namespace soda::viewer
