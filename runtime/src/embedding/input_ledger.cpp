#include "embedding/input_ledger.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "soda/scene/validate.h"
#include "soda/worlds/body_state.h"

namespace soda {

InputLedger::InputLedger(const Scene& scene) : settings_(scene.settings) {
  for (const Body& b : scene.bodies) lives_[b.id] = Life{b.is_static, b.kinematic};
  for (const Joint& j : scene.joints) joints_[j.id] = JointLife{j.body_a, j.body_b};
}

// A joint is there from the start (the scene's or the snapshot's) until its
// removal or that of one of its bodies, whichever comes first.
void InputLedger::check_joint(const UserInput& in, const std::string& what) const {
  auto it = joints_.find(in.joint);
  if (it == joints_.end()) throw std::invalid_argument(what + ": joint: no joint has that id");
  const JointLife& j = it->second;
  if (j.removed != INT64_MAX)
    throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) + " is removed at step " +
                                std::to_string(j.removed) + " already");
  for (BodyId b : {j.body_a, j.body_b}) {
    const Life& life = lives_.at(b);
    if (life.retired || in.step >= life.removed)
      throw std::invalid_argument(what + ": joint: joint " + std::to_string(in.joint) + " is gone then, with body " +
                                  std::to_string(b) + " (removed at step " +
                                  (life.retired ? std::string("before the snapshot this run was restored from")
                                                : std::to_string(life.removed)) +
                                  ")");
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
  if (in.kind == UserInput::Kind::RemoveJoint) return check_joint(in, what);
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
  if (life.kinematic && !moves_kinematic)
    throw std::invalid_argument(what + ": body " + std::to_string(in.id) +
                                " is kinematic: it is moved by its path, set_kinematic_target and set_pose only");
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
  if (!moves_kinematic && (!in.linear.allFinite() || !in.angular.allFinite()))
    throw std::invalid_argument(what + ": velocities and impulses must be finite");
  if (const std::string why = check_input_value(in); !why.empty()) throw std::invalid_argument(what + ": " + why);
}

void InputLedger::record(const UserInput& in) {
  if (in.kind == UserInput::Kind::SetGravity) return;  // names no body
  if (in.kind == UserInput::Kind::RemoveJoint) {
    // Its bodies cannot be removed before it (an input at a later step).
    JointLife& j = joints_.at(in.joint);
    j.removed = in.step;
    for (BodyId b : {j.body_a, j.body_b}) lives_[b].last_input = std::max(lives_[b].last_input, in.step);
    return;
  }
  const BodyId id = in.kind == UserInput::Kind::AddBody ? in.body.id : in.id;
  Life& life = lives_[id];
  if (in.kind == UserInput::Kind::AddBody) life.added = in.step;
  if (in.kind == UserInput::Kind::RemoveBody) life.removed = in.step;
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

}  // namespace soda
