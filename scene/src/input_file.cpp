// The input file format (docs/inputs.md). Input files are small (a log of
// user actions): they are read whole into a document, unlike scene files.
#include "soda/scene/input_file.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "json_context.h"

namespace soda {
namespace {

using detail::Context;
using detail::json;
using detail::vec_json;

constexpr const char* kInputsFormat = "soda-inputs";
constexpr int kInputsVersion = 1;

constexpr UserInput::Kind kAllKinds[] = {
    UserInput::Kind::AddBody,     UserInput::Kind::RemoveBody,     UserInput::Kind::SetVelocity,
    UserInput::Kind::ApplyImpulse, UserInput::Kind::SetGravity,    UserInput::Kind::SetMass,
    UserInput::Kind::SetFriction, UserInput::Kind::SetRestitution, UserInput::Kind::SetUserData,
    UserInput::Kind::SetPose,     UserInput::Kind::SetKinematicTarget, UserInput::Kind::RemoveJoint,
    UserInput::Kind::AddJoint, UserInput::Kind::SetJointMotor, UserInput::Kind::SetCollisionFilter};

// The file's field of a setter's value.
const char* value_field(UserInput::Kind kind) {
  switch (kind) {
    case UserInput::Kind::SetMass: return "mass";
    case UserInput::Kind::SetFriction: return "friction";
    case UserInput::Kind::SetRestitution: return "restitution";
    case UserInput::Kind::SetGravity: return "gravity";
    case UserInput::Kind::SetUserData: return "user_data";
    case UserInput::Kind::SetPose:
    case UserInput::Kind::SetKinematicTarget: return "position/orientation";
    case UserInput::Kind::SetJointMotor: return "velocity/max_impulse/axis";
    default: return "";
  }
}

UserInput::Kind parse_kind(const Context& ctx, const std::string& name) {
  for (UserInput::Kind k : kAllKinds)
    if (name == input_kind_name(k)) return k;
  ctx.fail("type", "unknown input '" + name +
                       "' (known: add_body, remove_body, set_velocity, apply_impulse, set_gravity, set_mass, "
                       "set_friction, set_restitution, set_user_data, set_pose, set_kinematic_target, remove_joint, "
                       "add_joint, set_joint_motor, set_collision_filter)");
}

BodyId parse_id(const Context& ctx, const json& j) {
  const std::int64_t id = ctx.integer(j, "id", true, 0);
  if (id < 0 || id > static_cast<std::int64_t>(kMaxBodyId)) ctx.fail("id", "must be in [0, 2^31)");
  return static_cast<BodyId>(id);
}

JointId parse_joint(const Context& ctx, const json& j) {
  const std::int64_t id = ctx.integer(j, "joint", true, 0);
  if (id < 0 || id > static_cast<std::int64_t>(kMaxJointId)) ctx.fail("joint", "must be in [0, 2^31)");
  return static_cast<JointId>(id);
}

Vec3 finite_vec3(const Context& ctx, const json& j, const char* field, bool required) {
  const Vec3 v = ctx.vec3(j, field, required, Vec3::Zero());
  if (!v.allFinite()) ctx.fail(field, "must be finite numbers");
  return v;
}

// "on" (default true); "velocity" and "max_impulse", required when on;
// "axis" for a spring-6dof joint.
void parse_motor(Context& ctx, const json& j, UserInput& in) {
  ctx.only_known(j, {"type", "step", "joint", "on", "velocity", "max_impulse", "axis"});
  in.joint = parse_joint(ctx, j);
  ctx.where += ": joint " + std::to_string(in.joint);
  JointMotor& m = in.motor;
  if (const json* on = ctx.find(j, "on", false)) {
    if (!on->is_boolean()) ctx.fail("on", std::string("must be true or false, got ") + on->type_name());
    m.on = on->get<bool>();
  } else {
    m.on = true;
  }
  m.velocity = ctx.number(j, "velocity", m.on, 0.0);
  m.max_impulse = ctx.number(j, "max_impulse", m.on, 0.0);
  if (!(m.max_impulse >= 0)) ctx.fail("max_impulse", "must be >= 0");
  const std::int64_t axis = ctx.integer(j, "axis", false, -1);
  if (ctx.find(j, "axis", false) && (axis < 0 || axis > 5))
    ctx.fail("axis", "must be in 0..5 (x, y, z linear, then angular)");
  m.axis = static_cast<int>(axis);
}

UserInput parse_input(const std::string& source, std::size_t index, const json& j) {
  Context ctx{source + ": input #" + std::to_string(index)};
  if (!j.is_object()) ctx.fail("(input)", "must be an object");
  UserInput in;
  in.kind = parse_kind(ctx, ctx.string(j, "type", true, ""));
  in.step = ctx.integer(j, "step", true, 0);
  if (in.step < 0) ctx.fail("step", "must be >= 0 (0: before the first step)");
  ctx.where += " (" + std::string(input_kind_name(in.kind)) + " at step " + std::to_string(in.step) + ")";
  switch (in.kind) {
    case UserInput::Kind::AddBody: {
      ctx.only_known(j, {"type", "step", "body"});
      in.body = detail::parse_body(ctx.where + ": body", *ctx.find(j, "body", true));
      if (in.body.is_static) ctx.fail("body.type", "only dynamic bodies can be added to a running scene");
      validate_body(in.body, ctx.where + ": body (id " + std::to_string(in.body.id) + ")");
      break;
    }
    case UserInput::Kind::RemoveBody:
      ctx.only_known(j, {"type", "step", "id"});
      in.id = parse_id(ctx, j);
      break;
    case UserInput::Kind::SetVelocity:
      ctx.only_known(j, {"type", "step", "id", "linear_velocity", "angular_velocity"});
      in.id = parse_id(ctx, j);
      in.linear = finite_vec3(ctx, j, "linear_velocity", true);
      in.angular = finite_vec3(ctx, j, "angular_velocity", false);
      break;
    case UserInput::Kind::ApplyImpulse:
      ctx.only_known(j, {"type", "step", "id", "impulse"});
      in.id = parse_id(ctx, j);
      in.linear = finite_vec3(ctx, j, "impulse", true);
      break;
    case UserInput::Kind::SetGravity:
      ctx.only_known(j, {"type", "step", "gravity"});
      in.linear = finite_vec3(ctx, j, "gravity", true);
      break;
    case UserInput::Kind::SetMass:
    case UserInput::Kind::SetFriction:
    case UserInput::Kind::SetRestitution: {
      const char* field = value_field(in.kind);
      ctx.only_known(j, {"type", "step", "id", field});
      in.id = parse_id(ctx, j);
      ctx.where += ": body " + std::to_string(in.id);
      in.value = ctx.number(j, field, true, 0.0);
      break;
    }
    case UserInput::Kind::SetUserData: {
      ctx.only_known(j, {"type", "step", "id", "user_data"});
      in.id = parse_id(ctx, j);
      const json* u = ctx.find(j, "user_data", true);
      if (!u->is_number_unsigned() && !(u->is_number_integer() && u->get<std::int64_t>() >= 0))
        ctx.fail("user_data", "must be an integer in [0, 2^64)");
      in.user_data = u->get<std::uint64_t>();
      break;
    }
    case UserInput::Kind::SetPose:
    case UserInput::Kind::SetKinematicTarget: {
      ctx.only_known(j, {"type", "step", "id", "position", "orientation"});
      in.id = parse_id(ctx, j);
      ctx.where += ": body " + std::to_string(in.id);
      in.linear = finite_vec3(ctx, j, "position", true);
      if (const json* q = ctx.find(j, "orientation", false)) {
        const Eigen::VectorXd v = ctx.numbers(*q, "orientation", 4);
        in.orientation = Quat(v[3], v[0], v[1], v[2]);  // file order x, y, z, w
      }
      break;
    }
    case UserInput::Kind::RemoveJoint:
      ctx.only_known(j, {"type", "step", "joint"});
      in.joint = parse_joint(ctx, j);
      break;
    case UserInput::Kind::AddJoint: {
      // The scene file's joint object and its checks; whether its bodies
      // are there (and not both static, not kinematic) the run decides.
      ctx.only_known(j, {"type", "step", "joint"});
      const std::string where = ctx.where + ": joint";
      in.added_joint = detail::parse_joint(where, *ctx.find(j, "joint", true));
      in.joint = in.added_joint.id;
      Body any;  // a dynamic body for either end
      validate_joint(in.added_joint, where + " (id " + std::to_string(in.joint) + ")", [&](BodyId id) {
        any.id = id;
        return &any;
      });
      break;
    }
    case UserInput::Kind::SetJointMotor: parse_motor(ctx, j, in); break;
    case UserInput::Kind::SetCollisionFilter:
      // The body's fields: "group" and "mask", both required (a filter
      // given whole, as the scene file's collision_group/collision_mask).
      ctx.only_known(j, {"type", "step", "id", "group", "mask"});
      in.id = parse_id(ctx, j);
      ctx.where += ": body " + std::to_string(in.id);
      ctx.find(j, "group", true);  // "missing" if absent
      ctx.find(j, "mask", true);
      in.collision_group = detail::filter_bits(ctx, j, "group", kDefaultCollisionGroup);
      in.collision_mask = detail::filter_bits(ctx, j, "mask", kAllCollisionGroups);
      break;
  }
  if (const std::string why = check_input_value(in); !why.empty()) ctx.fail(value_field(in.kind), why);
  return in;
}

}  // namespace

const char* input_kind_name(UserInput::Kind kind) {
  switch (kind) {
    case UserInput::Kind::AddBody: return "add_body";
    case UserInput::Kind::RemoveBody: return "remove_body";
    case UserInput::Kind::SetVelocity: return "set_velocity";
    case UserInput::Kind::ApplyImpulse: return "apply_impulse";
    case UserInput::Kind::SetGravity: return "set_gravity";
    case UserInput::Kind::SetMass: return "set_mass";
    case UserInput::Kind::SetFriction: return "set_friction";
    case UserInput::Kind::SetRestitution: return "set_restitution";
    case UserInput::Kind::SetUserData: return "set_user_data";
    case UserInput::Kind::SetPose: return "set_pose";
    case UserInput::Kind::SetKinematicTarget: return "set_kinematic_target";
    case UserInput::Kind::RemoveJoint: return "remove_joint";
    case UserInput::Kind::AddJoint: return "add_joint";
    case UserInput::Kind::SetJointMotor: return "set_joint_motor";
    case UserInput::Kind::SetCollisionFilter: return "set_collision_filter";
  }
  return "unknown";
}

bool names_body(UserInput::Kind kind) {
  return kind != UserInput::Kind::AddBody && kind != UserInput::Kind::SetGravity &&
         kind != UserInput::Kind::RemoveJoint && kind != UserInput::Kind::AddJoint &&
         kind != UserInput::Kind::SetJointMotor;
}

std::string check_input_value(const UserInput& in) {
  const auto got = [](double v) {
    std::ostringstream s;
    s << v;
    return ", got " + s.str();
  };
  switch (in.kind) {
    case UserInput::Kind::SetMass:
      if (!(in.value > 0) || !std::isfinite(in.value)) return "mass must be > 0 and finite" + got(in.value);
      break;
    case UserInput::Kind::SetFriction:
      if (!(in.value >= 0) || !std::isfinite(in.value)) return "friction must be >= 0 and finite" + got(in.value);
      break;
    case UserInput::Kind::SetRestitution:
      if (!(in.value >= 0 && in.value <= 1)) return "restitution must be in [0, 1]" + got(in.value);
      break;
    case UserInput::Kind::SetGravity:
      if (!in.linear.allFinite()) return "gravity must be finite numbers";
      break;
    case UserInput::Kind::SetPose:
    case UserInput::Kind::SetKinematicTarget: {
      if (!in.linear.allFinite()) {
        std::ostringstream s;
        s << "position must be finite numbers, got (" << in.linear.x() << ", " << in.linear.y() << ", "
          << in.linear.z() << ")";
        return s.str();
      }
      const Eigen::Vector4d q = in.orientation.coeffs();
      if (!q.allFinite()) return "orientation must be finite numbers";
      if (!(q.norm() > 1e-6)) return "orientation must be a non-zero quaternion";
      break;
    }
    case UserInput::Kind::SetJointMotor:
      if (!std::isfinite(in.motor.velocity)) return "velocity must be finite" + got(in.motor.velocity);
      if (!(in.motor.max_impulse >= 0) || !std::isfinite(in.motor.max_impulse))
        return "max_impulse must be >= 0 and finite" + got(in.motor.max_impulse);
      if (in.motor.axis < -1 || in.motor.axis > 5)
        return "axis must be 0..5 (a spring-6dof joint) or -1 (none)" + got(in.motor.axis);
      break;
    default: break;
  }
  return {};
}

std::vector<UserInput> parse_inputs_json(const std::string& text, const std::string& source) {
  json doc;
  try {
    doc = json::parse(text);
  } catch (const json::parse_error& e) {
    // The token the lexer stopped in: NaN, Infinity, ... get the hint.
    std::size_t end = std::min<std::size_t>(e.byte, text.size()), begin = end;
    while (begin > 0 && (std::isalpha(static_cast<unsigned char>(text[begin - 1])) || text[begin - 1] == '-' ||
                         text[begin - 1] == '+'))
      --begin;
    while (end < text.size() && std::isalpha(static_cast<unsigned char>(text[end]))) ++end;
    throw SceneError(source + ": at byte " + std::to_string(e.byte) + ": not valid JSON (" + e.what() + ")" +
                     (detail::looks_non_finite(text.substr(begin, end - begin))
                          ? "; numbers must be finite: JSON has no NaN or Infinity"
                          : ""));
  }
  Context ctx{source};
  if (!doc.is_object()) ctx.fail("(top level)", "must be an object");
  ctx.only_known(doc, {"format", "version", "inputs"});
  if (ctx.string(doc, "format", true, "") != kInputsFormat) ctx.fail("format", std::string("must be \"") + kInputsFormat + "\"");
  if (ctx.integer(doc, "version", true, 0) != kInputsVersion)
    ctx.fail("version", "unsupported version (this build reads version " + std::to_string(kInputsVersion) + ")");
  const json* list = ctx.find(doc, "inputs", true);
  if (!list->is_array()) ctx.fail("inputs", "must be an array");
  std::vector<UserInput> inputs;
  for (std::size_t i = 0; i < list->size(); ++i) {
    inputs.push_back(parse_input(source, i, (*list)[i]));
    inputs.back().sequence = i;  // the entry's index: names it in messages, orders one step's inputs
  }
  std::stable_sort(inputs.begin(), inputs.end(), [](const UserInput& a, const UserInput& b) { return a.step < b.step; });
  return inputs;
}

std::vector<UserInput> load_input_file(const std::string& path) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw SceneError(path + ": is a directory, not an input file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot open input file for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw SceneError(path + ": read error");
  return parse_inputs_json(text.str(), path);
}

std::string inputs_to_json(const std::vector<UserInput>& inputs) {
  json list = json::array();
  for (const UserInput& in : inputs) {
    json e = {{"type", input_kind_name(in.kind)}, {"step", in.step}};
    switch (in.kind) {
      case UserInput::Kind::AddBody: e["body"] = detail::body_json(in.body); break;
      case UserInput::Kind::RemoveBody: e["id"] = in.id; break;
      case UserInput::Kind::SetVelocity:
        e["id"] = in.id;
        e["linear_velocity"] = vec_json(in.linear);
        e["angular_velocity"] = vec_json(in.angular);
        break;
      case UserInput::Kind::ApplyImpulse:
        e["id"] = in.id;
        e["impulse"] = vec_json(in.linear);
        break;
      case UserInput::Kind::SetGravity: e["gravity"] = vec_json(in.linear); break;
      case UserInput::Kind::SetMass:
      case UserInput::Kind::SetFriction:
      case UserInput::Kind::SetRestitution:
        e["id"] = in.id;
        e[value_field(in.kind)] = in.value;
        break;
      case UserInput::Kind::SetUserData:
        e["id"] = in.id;
        e["user_data"] = in.user_data;
        break;
      case UserInput::Kind::SetPose:
      case UserInput::Kind::SetKinematicTarget:
        e["id"] = in.id;
        e["position"] = vec_json(in.linear);
        e["orientation"] =
            json::array({in.orientation.x(), in.orientation.y(), in.orientation.z(), in.orientation.w()});
        break;
      case UserInput::Kind::RemoveJoint: e["joint"] = in.joint; break;
      case UserInput::Kind::AddJoint: e["joint"] = detail::joint_json(in.added_joint); break;
      case UserInput::Kind::SetJointMotor:
        e["joint"] = in.joint;
        e["on"] = in.motor.on;
        e["velocity"] = in.motor.velocity;
        e["max_impulse"] = in.motor.max_impulse;
        if (in.motor.axis >= 0) e["axis"] = in.motor.axis;
        break;
      case UserInput::Kind::SetCollisionFilter:
        e["id"] = in.id;
        e["group"] = in.collision_group;
        e["mask"] = in.collision_mask;
        break;
    }
    list.push_back(std::move(e));
  }
  return json{{"format", kInputsFormat}, {"version", kInputsVersion}, {"inputs", std::move(list)}}.dump(1) + "\n";
}

}  // namespace soda
