// TerritoryWorld: joints (territory_world.h, invariant 6;
// docs/partitioned-step.md, "Joints"). The dynamic bodies that joints
// connect form a joint group whose home cell is its anchor's (its smallest
// body id): one world owns the whole group and holds its joints, as the
// canonical world does (joint_factory.h), so a joint is an island edge of
// that world's contact graph and travels in its fragment when the island
// spans a border. The group migrates whole, its joints in the batch.
#include <algorithm>
#include <map>
#include <stdexcept>
#include <string>

#include "joint_factory.h"
#include "soda/scene/joint_motor.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"

namespace soda {

std::unordered_map<BodyId, BodyId> joint_anchors(const std::vector<const Joint*>& joints,
                                                 const std::function<bool(BodyId)>& is_static) {
  std::unordered_map<BodyId, BodyId> parent;
  auto find = [&](BodyId x) {
    BodyId root = x;
    for (auto it = parent.find(root); it->second != root; it = parent.find(root)) root = it->second;
    while (x != root) {  // path compression
      BodyId& p = parent[x];
      x = p;
      p = root;
    }
    return root;
  };
  for (const Joint* j : joints)
    for (BodyId b : {j->body_a, j->body_b})
      if (!is_static(b)) parent.emplace(b, b);
  for (const Joint* j : joints) {
    if (is_static(j->body_a) || is_static(j->body_b)) continue;
    const BodyId a = find(j->body_a), b = find(j->body_b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);  // the root is the group's smallest id
  }
  std::unordered_map<BodyId, BodyId> anchors;
  for (const auto& [body, p] : parent) anchors.emplace(body, find(body));
  return anchors;
}

BodyId TerritoryWorld::anchor_of(BodyId id) const {
  auto it = anchor_.find(id);
  return it == anchor_.end() ? id : it->second;
}

WorldId TerritoryWorld::home_owner(const Entry& e) const {
  const BodyId anchor = anchor_of(e.id());
  if (anchor == e.id()) return owner_of_origin(e);
  auto it = entries_.find(anchor);
  if (it == entries_.end() || it->second->role != Role::Owned)
    throw std::logic_error("world " + std::to_string(id_) + ": body " + std::to_string(e.id()) +
                           " is owned here without the anchor of its joint group, body " + std::to_string(anchor));
  return owner_of_origin(*it->second);
}

void TerritoryWorld::insert_owned_and_joints(const std::vector<const Body*>& bodies,
                                             const std::vector<const BodyDynamicState*>& states,
                                             const std::vector<JointSnapshot>& joints) {
  std::unordered_map<BodyId, std::size_t> index;
  for (std::size_t i = 0; i < bodies.size(); ++i) index.emplace(bodies[i]->id, i);
  auto origin = [&](std::size_t i) {
    const BodyDynamicState* s = states[i];
    return s ? btVector3(s->origin[0], s->origin[1], s->origin[2]) : to_bt(bodies[i]->position);
  };
  std::vector<const Joint*> descriptions;
  for (const JointSnapshot& j : joints) {
    for (BodyId b : {j.description.body_a, j.description.body_b})
      if (!index.count(b) && !parts_->statics.is_static(b))
        throw std::invalid_argument("TerritoryWorld: joint " + std::to_string(j.description.id) + " joins body " +
                                    std::to_string(b) + ", which is not in the scene");
    descriptions.push_back(&j.description);
  }
  // The statics are known (held or in the catalog); every other body is dynamic.
  const std::unordered_map<BodyId, BodyId> anchors =
      joint_anchors(descriptions, [&](BodyId b) { return parts_->statics.is_static(b); });
  for (std::size_t i = 0; i < bodies.size(); ++i) {
    auto a = anchors.find(bodies[i]->id);
    const std::size_t home = a == anchors.end() ? i : index.at(a->second);
    // Home cell from the position as Bullet holds it (rounded to btScalar).
    if (owner_of_origin(origin(home)) != id_) continue;
    insert_dynamic(*bodies[i], states[i], true, id_);
    if (a != anchors.end()) anchor_.emplace(a->first, a->second);
  }
  for (const JointSnapshot& j : joints) {
    const BodyId dynamic =
        parts_->statics.is_static(j.description.body_a) ? j.description.body_b : j.description.body_a;
    if (owns(dynamic)) hold_joint(j.description, j.broken);
  }
}

void TerritoryWorld::hold_joint(const Joint& joint, bool broken) {
  Entry* ends[2] = {nullptr, nullptr};
  int i = 0;
  for (BodyId b : {joint.body_a, joint.body_b}) {
    parts_->statics.hold(b);  // a fixed static it ends on is held from now on
    auto it = entries_.find(b);
    if (it == entries_.end() || it->second->role == Role::Ghost)
      throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) + ": joint " +
                           std::to_string(joint.id) + " joins body " + std::to_string(b) +
                           ", which this world neither owns nor holds as a static body");
    ends[i++] = it->second.get();
  }
  if (ends[0]->role == Role::Static && ends[1]->role == Role::Static)
    throw std::invalid_argument("TerritoryWorld: joint " + std::to_string(joint.id) + " joins two static bodies");
  auto held = std::make_unique<HeldJoint>();
  held->description = joint;
  held->constraint = make_constraint(joint, *ends[0]->body, *ends[1]->body);
  held->constraint->setEnabled(!broken);
  parts_->world.addConstraint(held->constraint.get(), !joint.collide_connected);
  if (!joints_.emplace(joint.id, std::move(held)).second)
    throw PartitionError("world " + std::to_string(id_) + ": joint " + std::to_string(joint.id) + " held twice");
  for (Entry* e : ends)
    if (e->role == Role::Owned) ++e->joints;
  quiet_ = -1;
}

// A body removed by input takes its joints with it, broken or not, before
// it leaves the Bullet world (a constraint must not outlive its bodies); a
// joint removed by input goes alone. What is left of the joint group of
// `member` falls apart into the groups its remaining joints connect, each
// anchored by its own smallest id; the group's owner holds them all. A group
// whose new anchor's home cell belongs to another world migrates there,
// whole, at the end of the next step (as a body moved by set_pose does): one
// world alone holds each group throughout, so the step is the one world's.
void TerritoryWorld::drop_joints(BodyId member, JointId joint, bool all_of_member) {
  auto own = anchor_.find(member);
  if (own == anchor_.end()) return;
  const BodyId old_anchor = own->second;
  std::vector<const Joint*> kept;  // the group's other joints
  for (auto it = joints_.begin(); it != joints_.end();) {
    const Joint& j = it->second->description;
    if (all_of_member ? j.body_a != member && j.body_b != member : j.id != joint) {
      const auto a = anchor_.find(j.body_a), b = anchor_.find(j.body_b);
      if ((a != anchor_.end() && a->second == old_anchor) || (b != anchor_.end() && b->second == old_anchor))
        kept.push_back(&j);
      ++it;
      continue;
    }
    parts_->world.removeConstraint(it->second->constraint.get());
    for (BodyId body : {j.body_a, j.body_b})
      if (Entry& e = *entries_.at(body); e.role == Role::Owned) --e.joints;
    it = joints_.erase(it);
  }
  for (auto it = anchor_.begin(); it != anchor_.end();)
    it = it->second == old_anchor ? anchor_.erase(it) : std::next(it);
  for (const auto& [body, anchor] : joint_anchors(kept, [&](BodyId b) { return parts_->statics.is_static(b); }))
    anchor_.emplace(body, anchor);
  quiet_ = -1;
}

// Its dynamic ends wake (as an impulse wakes a body): a sleeping group
// falls apart at the next step. They are owned here with the joint and,
// jointed, never parked.
bool TerritoryWorld::remove_joint(JointId id) {
  auto it = joints_.find(id);
  if (it == joints_.end()) return false;
  const Joint j = it->second->description;
  std::vector<Entry*> ends;
  for (BodyId body : {j.body_a, j.body_b})
    if (Entry& e = *entries_.at(body); e.role == Role::Owned) ends.push_back(&e);
  drop_joints(ends.front()->id(), id, false);
  for (Entry* e : ends) {
    e->body->forceActivationState(ACTIVE_TAG);
    e->body->setDeactivationTime(btScalar(0));
  }
  return true;
}

// The input's validation (InputLedger) keeps a joint's dynamic ends in one
// world: a body pinned to a static one, or two of one joint group (one
// owner holds it). A group joined to another takes the smaller anchor; if
// that moves its home cell, the group migrates whole at the end of the
// next step, as after a body removal.
bool TerritoryWorld::add_joint(const Joint& joint) {
  std::vector<Entry*> ends;
  bool elsewhere = false;
  for (BodyId body : {joint.body_a, joint.body_b}) {
    if (parts_->statics.is_static(body)) continue;
    auto it = entries_.find(body);
    if (it != entries_.end() && it->second->role == Role::Owned)
      ends.push_back(it->second.get());
    else
      elsewhere = true;
  }
  if (ends.empty()) return false;
  if (elsewhere)
    throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) + ": joint " +
                         std::to_string(joint.id) + " added, but only one of its bodies is owned here");
  for (Entry* e : ends) unpark_for_input(*e);
  if (ends.size() == 2) {
    const BodyId a = anchor_of(ends[0]->id()), b = anchor_of(ends[1]->id());
    const BodyId kept = std::min(a, b), gone = std::max(a, b);
    for (auto& [body, anchor] : anchor_)
      if (anchor == gone) anchor = kept;
    for (BodyId body : {ends[0]->id(), ends[1]->id(), a, b}) anchor_[body] = kept;
  }
  hold_joint(joint, false);
  if (!joint.collide_connected) {
    // Its bodies stop colliding now, so their contact ends at this boundary:
    // in a world restored here (whose kept value of the pair would seed it)
    // as in one that never left it (whose manifold would keep stale points).
    // The kept value and the pair's algorithm and manifold go; the pair
    // stays in the broadphase, filtered by the joint from now on.
    kept_.erase({joint.body_a, joint.body_b});
    kept_.erase({joint.body_b, joint.body_a});
    btBroadphaseProxy* a = entries_.at(joint.body_a)->body->getBroadphaseHandle();
    btBroadphaseProxy* b = entries_.at(joint.body_b)->body->getBroadphaseHandle();
    if (btBroadphasePair* pair = a && b ? parts_->pairs.findPair(a, b) : nullptr)
      parts_->pairs.cleanOverlappingPair(*pair, &parts_->dispatcher);
  }
  for (Entry* e : ends) {
    e->body->forceActivationState(ACTIVE_TAG);
    e->body->setDeactivationTime(btScalar(0));
  }
  return true;
}

// The description takes the motor (joint_motor.h) and the constraint is
// made anew from it, broken or not as before: a joint carries nothing else
// from step to step (joint_factory.h), so it is the constraint a migration or
// a restore would make of the changed description, bit for bit. Its dynamic
// ends wake, as for a removal.
bool TerritoryWorld::set_joint_motor(JointId id, const JointMotor& motor) {
  auto it = joints_.find(id);
  if (it == joints_.end()) return false;
  HeldJoint& held = *it->second;
  const Joint changed = with_motor(held.description, motor);
  Entry& a = *entries_.at(changed.body_a);
  Entry& b = *entries_.at(changed.body_b);
  std::unique_ptr<btTypedConstraint> made = make_constraint(changed, *a.body, *b.body);
  made->setEnabled(held.constraint->isEnabled());
  parts_->world.removeConstraint(held.constraint.get());
  held.constraint = std::move(made);
  held.description = changed;
  parts_->world.addConstraint(held.constraint.get(), !changed.collide_connected);
  for (Entry* e : {&a, &b}) {
    if (e->role != Role::Owned) continue;
    e->body->forceActivationState(ACTIVE_TAG);
    e->body->setDeactivationTime(btScalar(0));
  }
  quiet_ = -1;
  return true;
}

std::size_t TerritoryWorld::broken_joint_count() const {
  std::size_t n = 0;
  for (const auto& [id, j] : joints_) n += j->constraint->isEnabled() ? 0 : 1;
  return n;
}

void TerritoryWorld::export_joints(const std::map<BodyId, WorldId>& destination,
                                   std::map<WorldId, MigrantBatch>& out) {
  for (auto it = joints_.begin(); it != joints_.end();) {
    const Joint& j = it->second->description;
    auto a = destination.find(j.body_a);
    auto b = destination.find(j.body_b);
    if (a == destination.end() && b == destination.end()) {
      ++it;
      continue;
    }
    const WorldId to = a != destination.end() ? a->second : b->second;
    for (BodyId body : {j.body_a, j.body_b}) {
      auto d = destination.find(body);
      if (d == destination.end() ? !parts_->statics.is_static(body) : d->second != to)
        throw std::logic_error("world " + std::to_string(id_) + ": joint " + std::to_string(j.id) +
                               " would be split by a migration");
    }
    btTypedConstraint* c = it->second->constraint.get();
    parts_->world.removeConstraint(c);
    out[to].joints.push_back(JointSnapshot{j, !c->isEnabled()});  // joints_ is by id: each batch's too
    for (BodyId body : {j.body_a, j.body_b}) {
      Entry& e = *entries_.at(body);
      if (e.role == Role::Owned) --e.joints;
      anchor_.erase(body);
    }
    it = joints_.erase(it);
  }
}

void TerritoryWorld::absorb_joints(const std::vector<std::pair<WorldId, MigrantBatch>>& batches) {
  for (const auto& [from, batch] : batches) {
    if (batch.joints.empty()) continue;
    std::vector<const Joint*> descriptions;
    for (const JointSnapshot& j : batch.joints) descriptions.push_back(&j.description);
    for (const auto& [body, anchor] :
         joint_anchors(descriptions, [&](BodyId b) { return parts_->statics.is_static(b); }))
      anchor_[body] = anchor;
    for (const JointSnapshot& j : batch.joints) hold_joint(j.description, j.broken);
  }
}

void TerritoryWorld::break_joint(JointId id) {
  auto it = joints_.find(id);
  if (it != joints_.end()) it->second->constraint->setEnabled(false);
}

btTypedConstraint* TerritoryWorld::BorderLink::held_joint(JointId id) const {
  auto it = world->joints_.find(id);
  return it == world->joints_.end() ? nullptr : it->second->constraint.get();
}

void TerritoryWorld::BorderLink::break_joint(JointId id) { world->break_joint(id); }

}  // namespace soda
