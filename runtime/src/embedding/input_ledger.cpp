#include "embedding/input_ledger.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "soda/scene/joint_motor.h"
#include "soda/scene/validate.h"
#include "soda/worlds/body_state.h"

namespace soda {

InputLedger::InputLedger(const Scene& scene) : settings_(scene.settings) {
  for (const Body& b : scene.bodies) lives_[b.id] = Life{b.is_static, b.kinematic};
  for (const Joint& j : scene.joints) joints_[j.id] = JointLife{j.body_a, j.body_b, j.kind};
}

// A joint is there from the start (the scene's or the snapshot's) or its
// addition until its removal or that of one of its bodies, whichever comes
// first. A joint is removed once, and not before a motor input queued for
// it; its motor is set while it is there, with values that fit its kind
// (joint_motor.h).
void InputLedger::check_joint(const UserInput& in, const std::string& what) const {
  auto it = joints_.find(in.joint);
  if (it == joints_.end()) throw std::invalid_argument(what + ": joint: no joint has that id");
  const JointLife& j = it->second;
  if (j.retired)
    throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) +
                                " was removed before the snapshot this run was restored from");
  const bool removal = in.kind == UserInput::Kind::RemoveJoint;
  if (j.removed.step != INT64_MAX && (removal || in.step >= j.removed.step))
    throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) + " is removed at step " +
                                std::to_string(j.removed.step) + " already");
  if (in.step < j.added.step)
    throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) + " is added at step " +
                                std::to_string(j.added.step) + " only");
  if (removal && j.last_motor > in.step)
    throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) +
                                " has a motor input at the later step " + std::to_string(j.last_motor));
  for (BodyId b : {j.body_a, j.body_b}) {
    const Life& life = lives_.at(b);
    if (life.retired || in.step >= life.removed)
      throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) + " is gone then, with body " +
                                  std::to_string(b) + " (removed at step " +
                                  (life.retired ? std::string("before the snapshot this run was restored from")
                                                : std::to_string(life.removed)) +
                                  ")");
  }
  if (!removal) {
    if (const std::string why = check_input_value(in); !why.empty()) throw std::invalid_argument(what + ": " + why);
    Joint kind_only;
    kind_only.id = in.joint;
    kind_only.kind = j.kind;
    if (const std::string why = check_joint_motor(kind_only, in.motor); !why.empty())
      throw std::invalid_argument(what + ": " + why);
    return;
  }
  check_loops_kept(in, what + ": joint");
}

bool InputLedger::dynamic(BodyId id) const {
  auto it = lives_.find(id);
  return it != lives_.end() && !it->second.is_static;
}

bool InputLedger::newborn(BodyId id, std::int64_t step) const {
  auto it = lives_.find(id);
  return it != lives_.end() && it->second.by_input && it->second.added == step;
}

BodyId InputLedger::anchor_in(const std::map<BodyId, BodyId>& groups, BodyId id) {
  auto it = groups.find(id);
  return it == groups.end() ? kNoGroup : it->second;
}

std::map<BodyId, BodyId> InputLedger::groups(Place at, Without without) const {
  std::map<BodyId, BodyId> parent;
  auto find = [&](BodyId x) {
    auto it = parent.find(x);
    while (it->second != x) {
      x = it->second;
      it = parent.find(x);
    }
    return x;
  };
  auto gone = [&](BodyId body) {
    if (without.body && *without.body == body) return true;
    const Life& life = lives_.at(body);
    return life.retired || Place{life.removed, life.removed_order} < at;
  };
  for (const auto& [id, j] : joints_) {
    if (!(j.added < at) || j.removed < at || (without.joint && *without.joint == id)) continue;
    if (!dynamic(j.body_a) || !dynamic(j.body_b) || gone(j.body_a) || gone(j.body_b)) continue;
    parent.emplace(j.body_a, j.body_a);
    parent.emplace(j.body_b, j.body_b);
    const BodyId x = find(j.body_a), y = find(j.body_b);
    if (x != y) parent[std::max(x, y)] = std::min(x, y);  // the root is the group's smallest id
  }
  std::map<BodyId, BodyId> out;
  for (const auto& [body, p] : parent) out.emplace(body, find(body));
  return out;
}

// A joint between two dynamic bodies is held by the one world that owns
// them both: they must be one joint group at that step (its owner holds it
// whole), or two groups (or free bodies) of bodies all added at that step,
// which the world owning the anchor's home cell takes whole (a group
// spawned: world_process.cpp), as the scene and the inputs alone say.
void InputLedger::check_added_joint(const UserInput& in, const std::string& what) const {
  const Joint& joint = in.added_joint;
  if (joint.id != in.joint)
    throw std::invalid_argument(what + ": id: the input names joint " + std::to_string(in.joint) +
                                " but carries joint " + std::to_string(joint.id));
  if (auto it = joints_.find(joint.id); it != joints_.end())
    throw std::invalid_argument(what + ": id: joint " + std::to_string(joint.id) + " is in use" +
                                (it->second.retired ? " (removed before the snapshot this run was restored "
                                                      "from; a joint's id is never used again)"
                                 : it->second.removed.step != INT64_MAX
                                     ? " (removed at step " + std::to_string(it->second.removed.step) +
                                           "; a joint's id is never used again)"
                                     : ""));
  for (const char* field : {"body_a", "body_b"}) {
    const BodyId b = field[5] == 'a' ? joint.body_a : joint.body_b;
    auto it = lives_.find(b);
    if (it == lives_.end())
      throw std::invalid_argument(what + ": " + field + ": no body has id " + std::to_string(b));
    const Life& life = it->second;
    if (life.retired)
      throw std::invalid_argument(what + ": " + field + ": body " + std::to_string(b) +
                                  " was removed before the snapshot this run was restored from");
    if (in.step < life.added || in.step >= life.removed)
      throw std::invalid_argument(what + ": " + field + ": body " + std::to_string(b) +
                                  " is not in the scene then (added at step " + std::to_string(life.added) +
                                  (life.removed == INT64_MAX ? "" : ", removed at step " + std::to_string(life.removed)) +
                                  ")");
  }
  // The scene file's rules for a joint (scene/validate.h), against what
  // the ledger knows of each body.
  Body ends[2];
  try {
    validate_joint(joint, what, [&](BodyId id) -> const Body* {
      Body& e = ends[id == joint.body_a ? 0 : 1];
      const Life& life = lives_.at(id);
      e.id = id, e.is_static = life.is_static, e.kinematic = life.kinematic;
      return &e;
    });
  } catch (const SceneError& e) {
    throw std::invalid_argument(e.what());
  }
  if (!dynamic(joint.body_a) || !dynamic(joint.body_b)) return;  // pinned to a static body: no group
  const std::map<BodyId, BodyId> now = groups(Place{in.step, order_ + 1}, Without{});
  const BodyId a = anchor_in(now, joint.body_a), b = anchor_in(now, joint.body_b);
  if (a == b && a != kNoGroup) return;  // a loop closed in one group
  auto spawned = [&](BodyId body, BodyId anchor) {
    if (anchor == kNoGroup) return newborn(body, in.step);
    for (const auto& [member, its] : now)
      if (its == anchor && !newborn(member, in.step)) return false;
    return true;
  };
  if (spawned(joint.body_a, a) && spawned(joint.body_b, b)) return;  // all added at this step
  auto group = [](BodyId body, BodyId anchor) {
    return anchor == kNoGroup ? "body " + std::to_string(body) + " is in no joint group"
                          : "body " + std::to_string(body) + " is in the joint group of body " + std::to_string(anchor);
  };
  throw std::invalid_argument(what + ": body_b: " + group(joint.body_a, a) + ", " + group(joint.body_b, b) +
                              "; a joint that joins two groups or free bodies cannot be added while the worlds run, "
                              "unless all their bodies are added at its step (docs/embedding.md, \"Joints\")");
}

// A removal (of a joint or a body) at a step before a joint added between
// two bodies of one group must leave them one group at that joint's step.
void InputLedger::check_loops_kept(const UserInput& removal, const std::string& what) const {
  const Without without{removal.kind == UserInput::Kind::RemoveJoint ? &removal.joint : nullptr,
                        removal.kind == UserInput::Kind::RemoveBody ? &removal.id : nullptr};
  for (const auto& [id, j] : joints_) {
    if (!j.closes_loop || j.added.step <= removal.step) continue;
    const std::map<BodyId, BodyId> then = groups(j.added, without);
    const BodyId a = anchor_in(then, j.body_a), b = anchor_in(then, j.body_b);
    if (a != b || a == kNoGroup)
      throw std::invalid_argument(what + ": it would split the joint group of bodies " + std::to_string(j.body_a) +
                                  " and " + std::to_string(j.body_b) + " before joint " + std::to_string(id) +
                                  ", added at step " + std::to_string(j.added.step) +
                                  ", closes a loop in it (remove that joint first)");
  }
}

void InputLedger::check(const UserInput& in) const {
  const std::string what = describe(in);
  if (in.step < 0) throw std::invalid_argument(what + ": the step must be >= 0");
  if (in.kind == UserInput::Kind::AddBody) {
    if (lives_.count(in.body.id)) throw std::invalid_argument(what + ": id " + std::to_string(in.body.id) + " is in use");
    if (in.body.is_static) throw std::invalid_argument(what + ": only dynamic bodies can be added to a running scene");
    Scene one;
    one.settings = settings_;
    one.bodies.push_back(in.body);
    try {
      validate_scene(one, "added body", kDoublePrecision ? Precision::Double : Precision::Float);
    } catch (const SceneError& e) {
      throw std::invalid_argument(what + ": " + e.what());
    }
    return;
  }
  if (in.kind == UserInput::Kind::RemoveJoint || in.kind == UserInput::Kind::SetJointMotor)
    return check_joint(in, what);
  if (in.kind == UserInput::Kind::AddJoint) return check_added_joint(in, what);
  if (in.kind == UserInput::Kind::SetGravity) {
    if (const std::string why = check_input_value(in); !why.empty()) throw std::invalid_argument(what + ": " + why);
    return;
  }
  auto it = lives_.find(in.id);
  if (it == lives_.end()) throw std::invalid_argument(what + ": no body has that id");
  const Life& life = it->second;
  const bool moves_kinematic =
      in.kind == UserInput::Kind::SetPose || in.kind == UserInput::Kind::SetKinematicTarget;
  if (in.kind == UserInput::Kind::SetKinematicTarget && !life.kinematic)
    throw std::invalid_argument(what + ": body " + std::to_string(in.id) +
                                " is not kinematic (set_kinematic_target moves kinematic bodies; set_pose puts any "
                                "body that is not static somewhere)");
  if (life.kinematic && !moves_kinematic && in.kind != UserInput::Kind::SetCollisionFilter)
    throw std::invalid_argument(what + ": body " + std::to_string(in.id) +
                                " is kinematic: it is moved by its path, set_kinematic_target and set_pose only, "
                                "and its collision filter changes by set_collision_filter");
  if (life.is_static && !life.kinematic) throw std::invalid_argument(what + ": the body is static");
  if (life.retired)
    throw std::invalid_argument(what + ": the body was removed before the snapshot this run was restored from");
  if (in.step < life.added || in.step >= life.removed)
    throw std::invalid_argument(what + ": the body is not in the scene then (added at step " +
                                std::to_string(life.added) +
                                (life.removed == INT64_MAX ? "" : ", removed at step " + std::to_string(life.removed)) +
                                ")");
  if (in.kind == UserInput::Kind::RemoveBody && life.last_input > in.step)
    throw std::invalid_argument(what + ": the body has an input at the later step " + std::to_string(life.last_input));
  if (in.kind == UserInput::Kind::RemoveBody) check_loops_kept(in, what);
  if (!moves_kinematic && (!in.linear.allFinite() || !in.angular.allFinite()))
    throw std::invalid_argument(what + ": velocities and impulses must be finite");
  if (const std::string why = check_input_value(in); !why.empty()) throw std::invalid_argument(what + ": " + why);
}

void InputLedger::record(const UserInput& in) {
  ++order_;
  if (in.kind == UserInput::Kind::SetGravity) return;  // names no body
  if (in.kind == UserInput::Kind::RemoveJoint || in.kind == UserInput::Kind::AddJoint ||
      in.kind == UserInput::Kind::SetJointMotor) {
    // Its bodies cannot be removed before it (an input at a later step).
    JointLife& j = joints_[in.joint];
    if (in.kind == UserInput::Kind::AddJoint) {
      j.body_a = in.added_joint.body_a, j.body_b = in.added_joint.body_b;
      j.kind = in.added_joint.kind;
      j.added = Place{in.step, order_};
      // A joint of a group spawned at its step relies on no earlier group.
      j.closes_loop = dynamic(j.body_a) && dynamic(j.body_b) && !newborn(j.body_a, in.step);
    } else if (in.kind == UserInput::Kind::RemoveJoint) {
      j.removed = Place{in.step, order_};
    } else {
      j.last_motor = std::max(j.last_motor, in.step);
    }
    for (BodyId b : {j.body_a, j.body_b}) lives_[b].last_input = std::max(lives_[b].last_input, in.step);
    return;
  }
  const BodyId id = in.kind == UserInput::Kind::AddBody ? in.body.id : in.id;
  Life& life = lives_[id];
  if (in.kind == UserInput::Kind::AddBody) life.added = in.step, life.by_input = true;
  if (in.kind == UserInput::Kind::RemoveBody) life.removed = in.step, life.removed_order = order_;
  life.last_input = std::max(life.last_input, in.step);
}

void InputLedger::retire(BodyId id) {
  Life& life = lives_[id];
  life.retired = true;
  life.removed = 0;
}

std::vector<BodyId> InputLedger::removed_before(std::int64_t step) const {
  std::vector<BodyId> out;
  for (const auto& [id, life] : lives_)
    if (life.retired || life.removed < step) out.push_back(id);
  return out;
}

void InputLedger::retire_joint(JointId id) {
  JointLife& j = joints_[id];
  j.retired = true;
  j.removed = Place{0, 0};
}

std::vector<JointId> InputLedger::joints_removed_before(std::int64_t step) const {
  std::vector<JointId> out;
  for (const auto& [id, j] : joints_)
    if (j.retired || j.removed.step < step) out.push_back(id);
  return out;
}

}  // namespace soda
