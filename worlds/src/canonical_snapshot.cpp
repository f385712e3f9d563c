// CanonicalWorld: snapshot export and restore into a fresh world.
//
// Restore order matters (traps found in Bullet 3.24):
//  1. bodies are created with their start transform in the construction info
//     (world-space inertia from it), then interpolation transform, velocities,
//     timers; all start ACTIVE so pairs' algorithms get manifolds (a box-box
//     algorithm created while both bodies are inactive never gets one);
//  2. broadphase pass (AABBs, pairs);
//  3. each snapshot manifold: its pair's algorithm is created (or found), and
//     the points are written back in their cache order;
//  4. activation states last.
#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

#include "canonical_world_parts.h"
#include "pair_manifold.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {

CanonicalWorld::CanonicalWorld(const WorldSnapshot& snapshot, const std::vector<std::size_t>& insertion_order) {
  build(snapshot.settings);
  steps_done_ = snapshot.steps_done;
  for (std::size_t i : resolve_insertion_order(insertion_order, snapshot.bodies.size())) {
    const BodySnapshot& b = snapshot.bodies[i];
    insert_body(b.description, &b.state);
  }
  std::sort(entries_.begin(), entries_.end(),
            [](const auto& a, const auto& b) { return a->description.id < b->description.id; });
  for (std::size_t i = 1; i < entries_.size(); ++i)
    if (entries_[i]->description.id == entries_[i - 1]->description.id)
      throw std::invalid_argument("CanonicalWorld: duplicate body id " +
                                  std::to_string(entries_[i]->description.id));
  std::vector<Joint> joints;
  std::vector<bool> broken;
  for (const JointSnapshot& j : snapshot.joints) joints.push_back(j.description), broken.push_back(j.broken);
  insert_joints(joints, &broken);
  import_manifolds(snapshot.manifolds);
  // 4. activation states last (statics stay as addRigidBody left them).
  for (const BodySnapshot& b : snapshot.bodies) {
    if (b.description.is_static) continue;
    btRigidBody& rb = *std::lower_bound(entries_.begin(), entries_.end(), b.description.id,
                                        [](const auto& e, BodyId id) { return e->description.id < id; })
                           ->get()
                           ->body;
    rb.forceActivationState(b.state.activation_state);
    rb.setDeactivationTime(b.state.deactivation_time);
  }
}

void CanonicalWorld::import_manifolds(const std::vector<ManifoldState>& manifolds) {
  auto find_body = [&](BodyId id) -> btRigidBody& {
    auto it = std::lower_bound(entries_.begin(), entries_.end(), id,
                               [](const auto& e, BodyId x) { return e->description.id < x; });
    if (it == entries_.end() || (*it)->description.id != id)
      throw std::invalid_argument("CanonicalWorld: manifold refers to unknown body " + std::to_string(id));
    return *(*it)->body;
  };
  CanonicalDynamicsWorld& world = parts_->world;
  // 2. broadphase pass: AABBs (with interpolation transforms) and pairs.
  world.updateAabbs();
  world.computeOverlappingPairs();
  btOverlappingPairCache* cache = parts_->broadphase.getOverlappingPairCache();
  for (const ManifoldState& ms : manifolds) {
    if (ms.points.empty()) continue;
    if (ms.points.size() > MANIFOLD_CACHE_SIZE)
      throw std::invalid_argument("CanonicalWorld: manifold with more than 4 points");
    btRigidBody& a = find_body(ms.id0);
    btRigidBody& b = find_body(ms.id1);
    btBroadphaseProxy* pa = a.getBroadphaseHandle();
    btBroadphaseProxy* pb = b.getBroadphaseHandle();
    btBroadphasePair* pair = cache->findPair(pa, pb);
    if (!pair) pair = cache->addOverlappingPair(pa, pb);
    if (!pair) throw std::logic_error("CanonicalWorld: pair cache refused a snapshot pair");
    // 3. the algorithm and its manifold as Bullet makes them.
    btPersistentManifold& m = pair_manifold(*pair, parts_->dispatcher, world.getDispatchInfo());
    if (static_cast<BodyId>(m.getBody0()->getUserIndex()) != ms.id0 ||
        static_cast<BodyId>(m.getBody1()->getUserIndex()) != ms.id1)
      throw std::logic_error("CanonicalWorld: manifold body order differs from the snapshot's");
    write_manifold_points(ms, m);
  }
}

std::vector<ManifoldState> CanonicalWorld::contact_state() const {
  std::vector<ManifoldState> out;
  btDispatcher& dispatcher = parts_->dispatcher;
  for (int i = 0; i < dispatcher.getNumManifolds(); ++i) {
    const btPersistentManifold* m = dispatcher.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    out.push_back(read_manifold_state(*m));
  }
  parts_->parking.append_contacts(out);
  std::sort(out.begin(), out.end(), [](const ManifoldState& a, const ManifoldState& b) {
    return a.id0 != b.id0 ? a.id0 < b.id0 : a.id1 < b.id1;
  });
  return out;
}

BodySnapshot CanonicalWorld::export_body(BodyId id) const {
  auto it = std::lower_bound(entries_.begin(), entries_.end(), id,
                             [](const auto& e, BodyId x) { return e->description.id < x; });
  if (it == entries_.end() || (*it)->description.id != id)
    throw std::out_of_range("CanonicalWorld::export_body: no body " + std::to_string(id));
  return BodySnapshot{(*it)->description, read_dynamic_state(*(*it)->body)};
}

WorldSnapshot CanonicalWorld::snapshot() const {
  WorldSnapshot s;
  s.settings = settings_;
  s.steps_done = steps_done_;
  s.bodies.reserve(entries_.size());
  for (const auto& e : entries_) s.bodies.push_back(BodySnapshot{e->description, read_dynamic_state(*e->body)});
  s.manifolds = contact_state();
  s.joints.reserve(joints_.size());
  for (const auto& j : joints_) s.joints.push_back(JointSnapshot{j->description, !j->constraint->isEnabled()});
  return s;
}

}  // namespace soda
