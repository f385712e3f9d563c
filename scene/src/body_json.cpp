// The body object of scene files (and of input files' add_body entries).
#include <set>
#include <string>

#include "json_context.h"

namespace soda::detail {
namespace {

ShapeKind parse_shape_kind(const Context& ctx, const std::string& name) {
  for (ShapeKind k : {ShapeKind::Box, ShapeKind::Sphere, ShapeKind::Capsule, ShapeKind::Cylinder,
                      ShapeKind::ConvexHull})
    if (name == shape_kind_name(k)) return k;
  ctx.fail("shape.type", "unknown shape '" + name +
                             "' (known: box, sphere, capsule, cylinder, convex_hull)");
}

Shape parse_shape(const Context& body_ctx, const json& j) {
  if (!j.is_object()) body_ctx.fail("shape", "must be an object");
  Context ctx{body_ctx.where};
  // Field names inside the shape are reported as shape.<name>.
  auto field = [](const char* f) { return std::string("shape.") + f; };
  auto it = j.find("type");
  if (it == j.end()) ctx.fail("shape.type", "missing");
  if (!it->is_string()) ctx.fail("shape.type", "must be a string");
  Shape s;
  s.kind = parse_shape_kind(ctx, it->get<std::string>());
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
  }
  for (auto f = j.begin(); f != j.end(); ++f)
    if (!allowed.count(f.key()))
      ctx.fail(field(f.key().c_str()), std::string("unknown field for a ") + shape_kind_name(s.kind));
  return s;
}

}  // namespace

Body parse_body(std::string where, const json& j) {
  Context ctx{std::move(where)};
  if (!j.is_object()) ctx.fail("(body)", "must be an object");
  const std::int64_t id = ctx.integer(j, "id", true, 0);
  if (id < 0 || id > static_cast<std::int64_t>(kMaxBodyId)) ctx.fail("id", "must be in [0, 2^31)");
  Body b;
  b.id = static_cast<BodyId>(id);
  ctx.where += " (id " + std::to_string(id) + ")";
  ctx.only_known(j, {"id", "type", "shape", "mass", "friction", "restitution", "position",
                     "orientation", "linear_velocity", "angular_velocity", "asleep"});
  const std::string type = ctx.string(j, "type", true, "");
  if (type != "static" && type != "dynamic") ctx.fail("type", "must be \"static\" or \"dynamic\"");
  b.is_static = type == "static";
  b.shape = parse_shape(ctx, *ctx.find(j, "shape", true));
  b.mass = ctx.number(j, "mass", !b.is_static, 0.0);
  b.friction = ctx.number(j, "friction", false, b.friction);
  b.restitution = ctx.number(j, "restitution", false, b.restitution);
  b.position = ctx.vec3(j, "position", true, Vec3::Zero());
  if (const json* q = ctx.find(j, "orientation", false)) {
    const Eigen::VectorXd v = ctx.numbers(*q, "orientation", 4);
    b.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
  }
  b.linear_velocity = ctx.vec3(j, "linear_velocity", false, Vec3::Zero());
  b.angular_velocity = ctx.vec3(j, "angular_velocity", false, Vec3::Zero());
  if (b.is_static && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
    ctx.fail("linear_velocity", "a static body cannot move");
  if (const json* a = ctx.find(j, "asleep", false)) {
    if (!a->is_boolean()) ctx.fail("asleep", "must be true or false");
    b.asleep = a->get<bool>();
    if (b.asleep && b.is_static) ctx.fail("asleep", "a static body cannot be asleep (only dynamic bodies sleep)");
    if (b.asleep && (!b.linear_velocity.isZero(0.0) || !b.angular_velocity.isZero(0.0)))
      ctx.fail("asleep", "a body created asleep must have zero linear_velocity and angular_velocity");
  }
  return b;
}

json body_json(const Body& b) {
  const auto vec_json = [](const Vec3& v) { return json::array({v.x(), v.y(), v.z()}); };
  json shape = {{"type", shape_kind_name(b.shape.kind)}};
  switch (b.shape.kind) {
    case ShapeKind::Box:
    case ShapeKind::Cylinder: shape["half_extents"] = vec_json(b.shape.half_extents); break;
    case ShapeKind::Sphere: shape["radius"] = b.shape.radius; break;
    case ShapeKind::Capsule:
      shape["radius"] = b.shape.radius;
      shape["height"] = b.shape.height;
      break;
    case ShapeKind::ConvexHull: {
      json pts = json::array();
      for (const Vec3& p : b.shape.points) pts.push_back(vec_json(p));
      shape["points"] = pts;
      break;
    }
  }
  json jb = {{"id", b.id},
             {"type", b.is_static ? "static" : "dynamic"},
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
  return jb;
}

}  // namespace soda::detail
