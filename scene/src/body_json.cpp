// The body object of scene files (and of input files' add_body entries).
#include <filesystem>
#include <set>
#include <string>

#include "json_context.h"
#include "soda/scene/obj_mesh.h"

namespace soda::detail {
namespace {

ShapeKind parse_shape_kind(const Context& ctx, const std::string& name, const std::string& at) {
  for (ShapeKind k : {ShapeKind::Box, ShapeKind::Sphere, ShapeKind::Capsule, ShapeKind::Cylinder,
                      ShapeKind::ConvexHull, ShapeKind::Compound, ShapeKind::TriangleMesh, ShapeKind::Heightfield})
    if (name == shape_kind_name(k)) return k;
  ctx.fail(at + ".type", "unknown shape '" + name +
                             "' (known: box, sphere, capsule, cylinder, convex_hull, compound, triangle_mesh, "
                             "heightfield)");
}

// A triangle mesh: inline vertices and indices, or an OBJ file beside the
// scene file (`base_dir`).
std::shared_ptr<const TriangleMeshData> parse_mesh(const Context& ctx, const json& j, const std::string& at,
                                                   const std::string& base_dir) {
  auto field = [&at](const std::string& f) { return at + "." + f; };
  auto file = j.find("file");
  if (file != j.end()) {
    if (j.contains("vertices") || j.contains("indices"))
      ctx.fail(field("file"), "a triangle mesh takes either a file or vertices and indices, not both");
    if (!file->is_string() || file->get<std::string>().empty()) ctx.fail(field("file"), "must be a file name");
    const std::string name = file->get<std::string>();
    const std::filesystem::path path = std::filesystem::path(name).is_absolute()
                                           ? std::filesystem::path(name)
                                           : std::filesystem::path(base_dir) / name;
    try {
      return read_obj_mesh(path.string(), name);
    } catch (const SceneError& e) {
      ctx.fail(field("file"), e.what());
    }
  }
  auto mesh = std::make_shared<TriangleMeshData>();
  auto v = j.find("vertices");
  if (v == j.end()) ctx.fail(field("vertices"), "missing (or give a file)");
  if (!v->is_array()) ctx.fail(field("vertices"), "must be an array of [x, y, z] points");
  mesh->vertices.reserve(v->size());
  for (std::size_t i = 0; i < v->size(); ++i)
    mesh->vertices.emplace_back(ctx.numbers((*v)[i], field("vertices[" + std::to_string(i) + "]"), 3));
  auto ix = j.find("indices");
  if (ix == j.end()) ctx.fail(field("indices"), "missing");
  if (!ix->is_array()) ctx.fail(field("indices"), "must be an array of [a, b, c] vertex index triples");
  mesh->triangles.reserve(ix->size());
  for (std::size_t t = 0; t < ix->size(); ++t) {
    const json& tri = (*ix)[t];
    const std::string f = field("indices[" + std::to_string(t) + "]");
    if (!tri.is_array() || tri.size() != 3) ctx.fail(f, "must be an array of 3 vertex indices");
    std::array<std::uint32_t, 3> out{};
    for (std::size_t k = 0; k < 3; ++k) {
      const json& n = tri[k];
      if (!n.is_number_integer() || (n.is_number_unsigned() ? n.get<std::uint64_t>() > 0xffffffffull
                                                            : n.get<std::int64_t>() < 0))
        ctx.fail(f, "vertex indices must be integers >= 0");
      out[k] = static_cast<std::uint32_t>(n.get<std::uint64_t>());
    }
    mesh->triangles.push_back(out);
  }
  return mesh;
}

std::shared_ptr<const HeightfieldData> parse_heightfield(const Context& ctx, const json& j, const std::string& at) {
  auto field = [&at](const char* f) { return at + "." + f; };
  auto hf = std::make_shared<HeightfieldData>();
  auto count = [&](const char* f) {
    auto v = j.find(f);
    if (v == j.end()) ctx.fail(field(f), "missing");
    if (!v->is_number_integer() || v->get<std::int64_t>() < 2 || v->get<std::int64_t>() > 0x7fffffff)
      ctx.fail(field(f), "must be an integer >= 2 (samples)");
    return static_cast<int>(v->get<std::int64_t>());
  };
  hf->columns = count("columns");
  hf->rows = count("rows");
  if (auto sp = j.find("spacing"); sp != j.end()) hf->spacing = Vec3(ctx.numbers(*sp, field("spacing"), 3));
  auto h = j.find("heights");
  if (h == j.end()) ctx.fail(field("heights"), "missing");
  if (!h->is_array()) ctx.fail(field("heights"), "must be an array of columns * rows numbers");
  hf->heights.reserve(h->size());
  for (std::size_t i = 0; i < h->size(); ++i) {
    if (!(*h)[i].is_number()) ctx.fail(at + ".heights[" + std::to_string(i) + "]", "must be a number");
    hf->heights.push_back((*h)[i].get<double>());
  }
  return hf;
}

// `at` names the shape's field: "shape", or "shape.children[i].shape".
// `base_dir`: the folder a mesh's file is relative to.
Shape parse_shape(const Context& body_ctx, const json& j, const std::string& at = "shape",
                  const std::string& base_dir = "") {
  if (!j.is_object()) body_ctx.fail(at, "must be an object");
  Context ctx{body_ctx.where};
  // Field names inside the shape are reported as <at>.<name>.
  auto field = [&at](const char* f) { return at + "." + f; };
  auto it = j.find("type");
  if (it == j.end()) ctx.fail(at + ".type", "missing");
  if (!it->is_string()) ctx.fail(at + ".type", "must be a string");
  Shape s;
  s.kind = parse_shape_kind(ctx, it->get<std::string>(), at);
  auto need = [&](const char* f) -> const json& {
    auto v = j.find(f);
    if (v == j.end()) ctx.fail(field(f), "missing");
    return *v;
  };
  auto scalar = [&](const char* f) {
    const json& v = need(f);
    if (!v.is_number()) ctx.fail(field(f), std::string("must be a number, got ") + v.type_name());
    return v.get<double>();
  };
  std::set<std::string> allowed{"type"};
  switch (s.kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder:
      s.half_extents = Vec3(ctx.numbers(need("half_extents"), field("half_extents"), 3));
      allowed.insert("half_extents");
      break;
    case ShapeKind::Sphere:
      s.radius = scalar("radius");
      allowed.insert("radius");
      break;
    case ShapeKind::Capsule:
      s.radius = scalar("radius");
      s.height = scalar("height");
      allowed.insert({"radius", "height"});
      break;
    case ShapeKind::ConvexHull: {
      const json& pts = need("points");
      if (!pts.is_array()) ctx.fail(field("points"), "must be an array of [x, y, z] points");
      for (const json& p : pts) s.points.emplace_back(ctx.numbers(p, field("points"), 3));
      allowed.insert("points");
      break;
    }
    case ShapeKind::Compound: {
      const json& kids = need("children");
      if (!kids.is_array()) ctx.fail(field("children"), "must be an array of {shape, position, orientation}");
      if (kids.empty()) ctx.fail(field("children"), "a compound needs at least one child shape");
      for (std::size_t i = 0; i < kids.size(); ++i) {
        const std::string child = at + ".children[" + std::to_string(i) + "]";
        const json& k = kids[i];
        if (!k.is_object()) ctx.fail(child, "must be an object {shape, position, orientation}");
        for (auto f = k.begin(); f != k.end(); ++f)
          if (f.key() != "shape" && f.key() != "position" && f.key() != "orientation")
            ctx.fail(child + "." + f.key(), "unknown field for a compound's child");
        auto ks = k.find("shape");
        if (ks == k.end()) ctx.fail(child + ".shape", "missing");
        CompoundChild c;
        c.shape = parse_shape(ctx, *ks, child + ".shape");
        if (c.shape.kind == ShapeKind::Compound)
          ctx.fail(child + ".shape.type",
                   "nested compounds are not supported: a compound's children are convex shapes (box, sphere, "
                   "capsule, cylinder, convex_hull)");
        if (auto p = k.find("position"); p != k.end()) c.position = Vec3(ctx.numbers(*p, child + ".position", 3));
        if (auto q = k.find("orientation"); q != k.end()) {
          const Eigen::VectorXd v = ctx.numbers(*q, child + ".orientation", 4);
          c.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
        }
        s.children.push_back(std::move(c));
      }
      allowed.insert("children");
      break;
    }
    case ShapeKind::TriangleMesh:
      s.mesh = parse_mesh(ctx, j, at, base_dir);
      allowed.insert({"vertices", "indices", "file"});
      break;
    case ShapeKind::Heightfield:
      s.heightfield = parse_heightfield(ctx, j, at);
      allowed.insert({"columns", "rows", "spacing", "heights"});
      break;
  }
  for (auto f = j.begin(); f != j.end(); ++f)
    if (!allowed.count(f.key()))
      ctx.fail(field(f.key().c_str()), std::string("unknown field for a ") + shape_kind_name(s.kind));
  return s;
}

// "path": {"keys": [{"time", "position", "orientation"}, ...], "loop"}.
KinematicPath parse_path(const Context& ctx, const json& j) {
  if (!j.is_object()) ctx.fail("path", "must be an object {keys, loop}");
  for (auto f = j.begin(); f != j.end(); ++f)
    if (f.key() != "keys" && f.key() != "loop") ctx.fail("path." + f.key(), "unknown field for a path");
  KinematicPath path;
  if (auto l = j.find("loop"); l != j.end()) {
    if (!l->is_boolean()) ctx.fail("path.loop", "must be true or false");
    path.loop = l->get<bool>();
  }
  auto ks = j.find("keys");
  if (ks == j.end()) ctx.fail("path.keys", "missing");
  if (!ks->is_array() || ks->empty()) ctx.fail("path.keys", "must be a non-empty array of {time, position, orientation}");
  for (std::size_t i = 0; i < ks->size(); ++i) {
    const std::string at = "path.keys[" + std::to_string(i) + "]";
    const json& k = (*ks)[i];
    if (!k.is_object()) ctx.fail(at, "must be an object {time, position, orientation}");
    for (auto f = k.begin(); f != k.end(); ++f)
      if (f.key() != "time" && f.key() != "position" && f.key() != "orientation")
        ctx.fail(at + "." + f.key(), "unknown field for a path key");
    PathKey key;
    auto t = k.find("time");
    if (t == k.end()) ctx.fail(at + ".time", "missing");
    if (!t->is_number()) ctx.fail(at + ".time", std::string("must be a number, got ") + t->type_name());
    key.time = t->get<double>();
    auto p = k.find("position");
    if (p == k.end()) ctx.fail(at + ".position", "missing");
    key.position = Vec3(ctx.numbers(*p, at + ".position", 3));
    if (auto q = k.find("orientation"); q != k.end()) {
      const Eigen::VectorXd v = ctx.numbers(*q, at + ".orientation", 4);
      key.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
    }
    path.keys.push_back(key);
  }
  return path;
}

}  // namespace

// A 32-bit collision group or mask: an integer in [0, 2^32).
std::uint32_t filter_bits(const Context& ctx, const json& j, const char* field, std::uint32_t fallback) {
  const json* v = ctx.find(j, field, false);
  if (!v) return fallback;
  if (!v->is_number_integer()) ctx.fail(field, std::string("must be an integer in [0, 2^32), got ") + v->type_name());
  if (v->is_number_unsigned() ? v->get<std::uint64_t>() > 0xffffffffull : v->get<std::int64_t>() < 0)
    ctx.fail(field, "must be an integer in [0, 2^32) (32 group bits)");
  return static_cast<std::uint32_t>(v->get<std::uint64_t>());
}


Body parse_body(std::string where, const json& j, const std::string& base_dir) {
  Context ctx{std::move(where)};
  if (!j.is_object()) ctx.fail("(body)", "must be an object");
  const std::int64_t id = ctx.integer(j, "id", true, 0);
  if (id < 0 || id > static_cast<std::int64_t>(kMaxBodyId)) ctx.fail("id", "must be in [0, 2^31)");
  Body b;
  b.id = static_cast<BodyId>(id);
  ctx.where += " (id " + std::to_string(id) + ")";
  ctx.only_known(j, {"id", "type", "shape", "mass", "friction", "restitution", "position",
                     "orientation", "linear_velocity", "angular_velocity", "asleep", "collision_group",
                     "collision_mask", "user_data", "sensor", "path"});
  const std::string type = ctx.string(j, "type", true, "");
  if (type != "static" && type != "dynamic" && type != "kinematic")
    ctx.fail("type", "must be \"static\", \"dynamic\" or \"kinematic\"");
  b.kinematic = type == "kinematic";
  b.is_static = type == "static" || b.kinematic;
  b.shape = parse_shape(ctx, *ctx.find(j, "shape", true), "shape", base_dir);
  if (b.kinematic && ctx.find(j, "mass", false))
    ctx.fail("mass", "a kinematic body has no mass (it is moved, never pushed: its mass is infinite)");
  b.mass = ctx.number(j, "mass", !b.is_static, 0.0);
  if (const json* path = ctx.find(j, "path", false)) {
    if (!b.kinematic) ctx.fail("path", "only kinematic bodies have a path");
    b.path = parse_path(ctx, *path);
  }
  b.friction = ctx.number(j, "friction", false, b.friction);
  b.restitution = ctx.number(j, "restitution", false, b.restitution);
  // A kinematic body with a path starts where its path does.
  const bool from_path = !b.path.keys.empty();
  b.position = ctx.vec3(j, "position", !from_path, from_path ? b.path.keys.front().position : Vec3::Zero());
  if (from_path && !ctx.find(j, "orientation", false)) b.orientation = b.path.keys.front().orientation;
  if (const json* q = ctx.find(j, "orientation", false)) {
    const Eigen::VectorXd v = ctx.numbers(*q, "orientation", 4);
    b.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
  }
  b.linear_velocity = ctx.vec3(j, "linear_velocity", false, Vec3::Zero());
  b.angular_velocity = ctx.vec3(j, "angular_velocity", false, Vec3::Zero());
  if (b.is_static && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
    ctx.fail("linear_velocity", b.kinematic ? "a kinematic body's velocities come from its path (give it a path)"
                                            : "a static body cannot move");
  if (const json* a = ctx.find(j, "asleep", false)) {
    if (!a->is_boolean()) ctx.fail("asleep", "must be true or false");
    b.asleep = a->get<bool>();
    if (b.asleep && b.is_static)
      ctx.fail("asleep", std::string("a ") + (b.kinematic ? "kinematic" : "static") +
                             " body cannot be asleep (only dynamic bodies sleep)");
    if (b.asleep && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
      ctx.fail("asleep", "a body created asleep must have zero linear_velocity and angular_velocity");
  }
  b.collision_group = filter_bits(ctx, j, "collision_group", b.collision_group);
  b.collision_mask = filter_bits(ctx, j, "collision_mask", b.collision_mask);
  if (const json* u = ctx.find(j, "user_data", false)) {
    if (!u->is_number_unsigned() && !(u->is_number_integer() && u->get<std::int64_t>() >= 0))
      ctx.fail("user_data", "must be an integer in [0, 2^64)");
    b.user_data = u->get<std::uint64_t>();
  }
  if (const json* s = ctx.find(j, "sensor", false)) {
    if (!s->is_boolean()) ctx.fail("sensor", "must be true or false");
    b.sensor = s->get<bool>();
  }
  return b;
}

namespace {

json shape_json(const Shape& s) {
  json shape = {{"type", shape_kind_name(s.kind)}};
  switch (s.kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder: shape["half_extents"] = vec_json(s.half_extents); break;
    case ShapeKind::Sphere: shape["radius"] = s.radius; break;
    case ShapeKind::Capsule:
      shape["radius"] = s.radius;
      shape["height"] = s.height;
      break;
    case ShapeKind::ConvexHull: {
      json pts = json::array();
      for (const Vec3& p : s.points) pts.push_back(vec_json(p));
      shape["points"] = pts;
      break;
    }
    case ShapeKind::Compound: {
      json kids = json::array();
      for (const CompoundChild& c : s.children)
        kids.push_back({{"shape", shape_json(c.shape)},
                        {"position", vec_json(c.position)},
                        {"orientation", json::array({c.orientation.x(), c.orientation.y(), c.orientation.z(),
                                                     c.orientation.w()})}});
      shape["children"] = kids;
      break;
    }
    case ShapeKind::TriangleMesh: {
      if (!s.mesh) break;
      if (!s.mesh->file.empty()) {  // as the scene named it: the file stays beside the scene
        shape["file"] = s.mesh->file;
        break;
      }
      json vertices = json::array(), indices = json::array();
      for (const Vec3& v : s.mesh->vertices) vertices.push_back(vec_json(v));
      for (const auto& t : s.mesh->triangles) indices.push_back(json::array({t[0], t[1], t[2]}));
      shape["vertices"] = std::move(vertices);
      shape["indices"] = std::move(indices);
      break;
    }
    case ShapeKind::Heightfield: {
      if (!s.heightfield) break;
      shape["columns"] = s.heightfield->columns;
      shape["rows"] = s.heightfield->rows;
      shape["spacing"] = vec_json(s.heightfield->spacing);
      shape["heights"] = s.heightfield->heights;
      break;
    }
  }
  return shape;
}

}  // namespace

json body_json(const Body& b) {
  const json shape = shape_json(b.shape);
  json jb = {{"id", b.id},
             {"type", b.kinematic ? "kinematic" : (b.is_static ? "static" : "dynamic")},
             {"shape", shape},
             {"friction", b.friction},
             {"restitution", b.restitution},
             {"position", vec_json(b.position)},
             {"orientation",
              json::array({b.orientation.x(), b.orientation.y(), b.orientation.z(), b.orientation.w()})}};
  if (!b.is_static) {
    jb["mass"] = b.mass;
    jb["linear_velocity"] = vec_json(b.linear_velocity);
    jb["angular_velocity"] = vec_json(b.angular_velocity);
    if (b.asleep) jb["asleep"] = true;
  }
  // Written only when not the default, so that files without filters stay
  // as they were.
  if (b.collision_group != kDefaultCollisionGroup) jb["collision_group"] = b.collision_group;
  if (b.collision_mask != kAllCollisionGroups) jb["collision_mask"] = b.collision_mask;
  if (b.user_data != 0) jb["user_data"] = b.user_data;  // absent: 0
  if (b.sensor) jb["sensor"] = true;
  if (!b.path.keys.empty()) {
    json keys = json::array();
    for (const PathKey& k : b.path.keys)
      keys.push_back({{"time", k.time},
                      {"position", vec_json(k.position)},
                      {"orientation", json::array({k.orientation.x(), k.orientation.y(), k.orientation.z(),
                                                   k.orientation.w()})}});
    jb["path"] = {{"keys", keys}};
    if (b.path.loop) jb["path"]["loop"] = true;
  }
  return jb;
}

}  // namespace soda::detail
