// The joint object of scene files (docs/scene-format.md, "Joints").
#include <cmath>
#include <set>
#include <string>

#include "json_context.h"

namespace soda::detail {
namespace {

constexpr JointKind kJointKinds[] = {JointKind::PointToPoint, JointKind::Hinge,     JointKind::Slider,
                                     JointKind::ConeTwist,    JointKind::Fixed,     JointKind::Spring6Dof};

json frame_json(const JointFrame& f) {
  return {{"position", vec_json(f.position)},
          {"orientation", json::array({f.orientation.x(), f.orientation.y(), f.orientation.z(), f.orientation.w()})}};
}

JointFrame parse_frame(const Context& ctx, const json& j, const std::string& field) {
  if (!j.is_object()) ctx.fail(field, "must be an object with position and orientation");
  for (auto f = j.begin(); f != j.end(); ++f)
    if (f.key() != "position" && f.key() != "orientation") ctx.fail(field + "." + f.key(), "unknown field");
  JointFrame frame;
  if (auto p = j.find("position"); p != j.end()) frame.position = Vec3(ctx.numbers(*p, field + ".position", 3));
  if (auto q = j.find("orientation"); q != j.end()) {
    const Eigen::VectorXd v = ctx.numbers(*q, field + ".orientation", 4);
    frame.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
  }
  return frame;
}

std::array<double, 6> six(const Context& ctx, const json& axes, const char* name, const std::array<double, 6>& fallback) {
  auto it = axes.find(name);
  if (it == axes.end()) return fallback;
  const Eigen::VectorXd v = ctx.numbers(*it, std::string("axes.") + name, 6);
  std::array<double, 6> out{};
  for (int i = 0; i < 6; ++i) out[static_cast<std::size_t>(i)] = v[i];
  return out;
}

json six_json(const std::array<double, 6>& a) { return json::array({a[0], a[1], a[2], a[3], a[4], a[5]}); }

std::pair<double, double> pair_of(const Context& ctx, const json& j, const char* field) {
  const Eigen::VectorXd v = ctx.numbers(*ctx.find(j, field, true), field, 2);
  return {v[0], v[1]};
}

}  // namespace

JointKind parse_joint_kind(const Context& ctx, const std::string& name) {
  for (JointKind k : kJointKinds)
    if (name == joint_kind_name(k)) return k;
  ctx.fail("type", "unknown joint type '" + name +
                       "' (known: point-to-point, hinge, slider, cone-twist, fixed, spring-6dof)");
}

Joint parse_joint(std::string where, const json& j) {
  Context ctx{std::move(where)};
  if (!j.is_object()) ctx.fail("(joint)", "must be an object");
  const std::int64_t id = ctx.integer(j, "id", true, 0);
  if (id < 0 || id > static_cast<std::int64_t>(kMaxJointId)) ctx.fail("id", "must be in [0, 2^31)");
  Joint joint;
  joint.id = static_cast<JointId>(id);
  ctx.where += " (id " + std::to_string(id) + ")";
  joint.kind = parse_joint_kind(ctx, ctx.string(j, "type", true, ""));
  std::set<std::string> allowed{"id", "type", "body_a", "body_b", "frame_a", "frame_b", "collide_connected",
                                "breaking_impulse"};
  switch (joint.kind) {
    case JointKind::Hinge: allowed.insert({"limit", "motor"}); break;
    case JointKind::Slider: allowed.insert({"limit", "angular_limit", "motor"}); break;
    case JointKind::ConeTwist: allowed.insert("spans"); break;
    case JointKind::Spring6Dof: allowed.insert("axes"); break;
    case JointKind::PointToPoint:
    case JointKind::Fixed: break;
  }
  for (auto f = j.begin(); f != j.end(); ++f)
    if (!allowed.count(f.key()))
      ctx.fail(f.key(), std::string("unknown field for a ") + joint_kind_name(joint.kind) + " joint");
  for (const char* body : {"body_a", "body_b"}) {
    const std::int64_t b = ctx.integer(j, body, true, 0);
    if (b < 0 || b > static_cast<std::int64_t>(kMaxBodyId)) ctx.fail(body, "must be a body id in [0, 2^31)");
    (body[5] == 'a' ? joint.body_a : joint.body_b) = static_cast<BodyId>(b);
  }
  if (const json* f = ctx.find(j, "frame_a", false)) joint.frame_a = parse_frame(ctx, *f, "frame_a");
  if (const json* f = ctx.find(j, "frame_b", false)) joint.frame_b = parse_frame(ctx, *f, "frame_b");
  if (const json* c = ctx.find(j, "collide_connected", false)) {
    if (!c->is_boolean()) ctx.fail("collide_connected", "must be true or false");
    joint.collide_connected = c->get<bool>();
  }
  joint.breaking_impulse = ctx.number(j, "breaking_impulse", false, joint.breaking_impulse);
  if (j.contains("limit")) {
    joint.limited = true;
    std::tie(joint.lower, joint.upper) = pair_of(ctx, j, "limit");
  }
  if (j.contains("angular_limit")) std::tie(joint.angular_lower, joint.angular_upper) = pair_of(ctx, j, "angular_limit");
  if (const json* m = ctx.find(j, "motor", false)) {
    if (!m->is_object()) ctx.fail("motor", "must be an object with velocity and max_impulse");
    Context mc{ctx.where};
    for (auto f = m->begin(); f != m->end(); ++f)
      if (f.key() != "velocity" && f.key() != "max_impulse") ctx.fail("motor." + f.key(), "unknown field");
    joint.motor = true;
    if (!m->contains("velocity") || !(*m)["velocity"].is_number()) ctx.fail("motor.velocity", "must be a number");
    if (!m->contains("max_impulse") || !(*m)["max_impulse"].is_number())
      ctx.fail("motor.max_impulse", "must be a number");
    joint.motor_velocity = (*m)["velocity"].get<double>();
    joint.motor_max_impulse = (*m)["max_impulse"].get<double>();
  }
  if (const json* s = ctx.find(j, "spans", false)) {
    const Eigen::VectorXd v = ctx.numbers(*s, "spans", 3);
    joint.swing_span1 = v[0], joint.swing_span2 = v[1], joint.twist_span = v[2];
  }
  if (const json* a = ctx.find(j, "axes", false)) {
    if (!a->is_object()) ctx.fail("axes", "must be an object");
    for (auto f = a->begin(); f != a->end(); ++f)
      if (!std::set<std::string>{"lower", "upper", "stiffness", "damping", "motor_velocity", "motor_max_force"}.count(
              f.key()))
        ctx.fail("axes." + f.key(), "unknown field");
    joint.axis_lower = six(ctx, *a, "lower", joint.axis_lower);
    joint.axis_upper = six(ctx, *a, "upper", joint.axis_upper);
    joint.stiffness = six(ctx, *a, "stiffness", joint.stiffness);
    joint.damping = six(ctx, *a, "damping", joint.damping);
    joint.motor_velocities = six(ctx, *a, "motor_velocity", joint.motor_velocities);
    joint.motor_max_forces = six(ctx, *a, "motor_max_force", joint.motor_max_forces);
  }
  return joint;
}

json joint_json(const Joint& joint) {
  json j = {{"id", joint.id},
            {"type", joint_kind_name(joint.kind)},
            {"body_a", joint.body_a},
            {"body_b", joint.body_b},
            {"frame_a", frame_json(joint.frame_a)},
            {"frame_b", frame_json(joint.frame_b)}};
  if (joint.collide_connected) j["collide_connected"] = true;
  if (std::isfinite(joint.breaking_impulse)) j["breaking_impulse"] = joint.breaking_impulse;
  switch (joint.kind) {
    case JointKind::Hinge:
    case JointKind::Slider:
      if (joint.limited) j["limit"] = json::array({joint.lower, joint.upper});
      if (joint.kind == JointKind::Slider) j["angular_limit"] = json::array({joint.angular_lower, joint.angular_upper});
      if (joint.motor) j["motor"] = {{"velocity", joint.motor_velocity}, {"max_impulse", joint.motor_max_impulse}};
      break;
    case JointKind::ConeTwist: j["spans"] = json::array({joint.swing_span1, joint.swing_span2, joint.twist_span}); break;
    case JointKind::Spring6Dof:
      j["axes"] = {{"lower", six_json(joint.axis_lower)},         {"upper", six_json(joint.axis_upper)},
                   {"stiffness", six_json(joint.stiffness)},       {"damping", six_json(joint.damping)},
                   {"motor_velocity", six_json(joint.motor_velocities)},
                   {"motor_max_force", six_json(joint.motor_max_forces)}};
      break;
    case JointKind::PointToPoint:
    case JointKind::Fixed: break;
  }
  return j;
}

}  // namespace soda::detail
