#include "embedding/census.h"

#include <algorithm>
#include <iterator>
#include <stdexcept>
#include <string>
#include <tuple>

#include "soda/scene/kinematic_command.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {

Census::Census(const Scene& scene) : settings_(scene.settings) {
  for (const Body& b : scene.bodies) {
    if (b.is_static) {
      statics_.push_back(b);
      if (b.kinematic) kinematic_.emplace(b.id, b);
      continue;
    }
    scene_.push_back(b.id);
    dynamics_.emplace(b.id, b);
  }
  std::sort(scene_.begin(), scene_.end());
  std::sort(statics_.begin(), statics_.end(), [](const Body& a, const Body& b) { return a.id < b.id; });
}

const Body* Census::description(BodyId id) const {
  std::lock_guard lock(mutex_);
  auto it = dynamics_.find(id);
  if (it != dynamics_.end()) return &it->second;
  auto s = std::lower_bound(statics_.begin(), statics_.end(), id, [](const Body& b, BodyId i) { return b.id < i; });
  return s != statics_.end() && s->id == id ? &*s : nullptr;
}

void Census::record(const UserInput& in) {
  std::lock_guard lock(mutex_);
  if (in.kind == UserInput::Kind::AddBody) {
    dynamics_.emplace(in.body.id, in.body);
    changed_[in.body.id].first = in.step + 1;
  } else if (in.kind == UserInput::Kind::RemoveBody) {
    // A scene body has first = 0 (default); an added one keeps its first.
    changed_[in.id].end = in.step + 1;
  } else if (in.kind == UserInput::Kind::SetMass || in.kind == UserInput::Kind::SetFriction ||
             in.kind == UserInput::Kind::SetRestitution || in.kind == UserInput::Kind::SetUserData ||
             in.kind == UserInput::Kind::SetCollisionFilter) {
    std::vector<UserInput>& list = property_changes_[in.id];
    const auto key = [](const UserInput& i) { return std::make_pair(i.step, i.sequence); };
    list.insert(std::upper_bound(list.begin(), list.end(), in,
                                 [&](const UserInput& a, const UserInput& b) { return key(a) < key(b); }),
                in);
    if (auto it = kinematic_.find(in.id); it != kinematic_.end())  // as every world does
      record_command(it->second.filter_commands, FilterCommand{in.step, in.collision_group, in.collision_mask});
  } else if (in.kind == UserInput::Kind::SetPose || in.kind == UserInput::Kind::SetKinematicTarget) {
    auto it = kinematic_.find(in.id);
    if (it == kinematic_.end()) return;  // a dynamic body's set_pose: in its owner's frames
    record_command(it->second.commands, kinematic_command(in));  // as every world does
  }
}

std::vector<BodyState> Census::kinematic_states(std::int64_t step) const {
  std::lock_guard lock(mutex_);
  std::vector<BodyState> out;
  out.reserve(kinematic_.size());
  for (const auto& [id, b] : kinematic_) out.push_back(kinematic_state(b, settings_, step * settings_.substeps));
  return out;
}

bool Census::properties(BodyId id, std::int64_t step, Body& out) const {
  std::lock_guard lock(mutex_);
  auto it = dynamics_.find(id);
  if (it == dynamics_.end()) {
    auto s = std::lower_bound(statics_.begin(), statics_.end(), id, [](const Body& b, BodyId i) { return b.id < i; });
    if (s == statics_.end() || s->id != id) return false;
    out = *s;
    if (auto k = kinematic_.find(id); k != kinematic_.end()) {
      // A kinematic body's filter inputs: in frames after their boundary.
      out.filter_commands = k->second.filter_commands;
      std::tie(out.collision_group, out.collision_mask) = collision_filter_before(out, step, 1);
    }
    return true;
  }
  out = it->second;
  auto changes = property_changes_.find(id);
  if (changes == property_changes_.end()) return true;
  // An input at boundary s is in frames s + 1 onwards.
  for (const UserInput& in : changes->second) {
    if (in.step >= step) break;
    switch (in.kind) {
      case UserInput::Kind::SetMass: out.mass = in.value; break;
      case UserInput::Kind::SetFriction: out.friction = in.value; break;
      case UserInput::Kind::SetRestitution: out.restitution = in.value; break;
      case UserInput::Kind::SetUserData: out.user_data = in.user_data; break;
      case UserInput::Kind::SetCollisionFilter:
        out.collision_group = in.collision_group;
        out.collision_mask = in.collision_mask;
        break;
      default: break;
    }
  }
  return true;
}

bool Census::holds_locked(BodyId id, std::int64_t step) const {
  if (auto it = changed_.find(id); it != changed_.end()) return it->second.holds(step);
  return std::binary_search(scene_.begin(), scene_.end(), id);
}

std::size_t Census::count_at_locked(std::int64_t step) const {
  std::size_t n = scene_.size();
  for (const auto& [id, span] : changed_) {
    const bool in_scene = std::binary_search(scene_.begin(), scene_.end(), id);
    if (in_scene && !span.holds(step)) --n;
    if (!in_scene && span.holds(step)) ++n;
  }
  return n;
}

std::size_t Census::count_at(std::int64_t step) const {
  std::lock_guard lock(mutex_);
  return count_at_locked(step);
}

void Census::check(std::int64_t step, const std::vector<BodyId>& ids) const {
  std::lock_guard lock(mutex_);
  const std::string at = "SceneReader: step " + std::to_string(step);
  for (BodyId id : ids)
    if (!holds_locked(id, step))
      throw std::logic_error(at + " holds body " + std::to_string(id) + ", which is not in the scene at that step");
  const std::size_t expected = count_at_locked(step);
  if (ids.size() == expected) return;
  // Every id held is alive, so some alive body is missing: name the first.
  std::vector<BodyId> alive;
  for (BodyId id : scene_)
    if (holds_locked(id, step)) alive.push_back(id);
  for (const auto& [id, span] : changed_)
    if (span.holds(step) && !std::binary_search(scene_.begin(), scene_.end(), id)) alive.push_back(id);
  std::sort(alive.begin(), alive.end());
  std::vector<BodyId> missing;
  std::set_difference(alive.begin(), alive.end(), ids.begin(), ids.end(), std::back_inserter(missing));
  throw std::logic_error(at + " holds " + std::to_string(ids.size()) + " bodies, the scene has " +
                         std::to_string(expected) + " dynamic bodies at that step" +
                         (missing.empty() ? std::string() : "; body " + std::to_string(missing.front()) + " is missing"));
}

}  // namespace soda
