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

#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>

#include "canonical_world_parts.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {
namespace {

void put3(btScalar* out, const btVector3& v) {
  for (int i = 0; i < 3; ++i) out[i] = v[i];
}
btVector3 get3(const btScalar* in) { return btVector3(in[0], in[1], in[2]); }

void put_transform(btScalar* basis, btScalar* origin, const btTransform& t) {
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) basis[r * 3 + c] = t.getBasis()[r][c];
  put3(origin, t.getOrigin());
}

ContactPointState to_state(const btManifoldPoint& p) {
  ContactPointState s{};
  put3(s.local_point_a, p.m_localPointA);
  put3(s.local_point_b, p.m_localPointB);
  put3(s.position_world_on_b, p.m_positionWorldOnB);
  put3(s.position_world_on_a, p.m_positionWorldOnA);
  put3(s.normal_world_on_b, p.m_normalWorldOnB);
  s.distance = p.m_distance1;
  s.combined_friction = p.m_combinedFriction;
  s.combined_rolling_friction = p.m_combinedRollingFriction;
  s.combined_spinning_friction = p.m_combinedSpinningFriction;
  s.combined_restitution = p.m_combinedRestitution;
  s.part_id0 = p.m_partId0;
  s.part_id1 = p.m_partId1;
  s.index0 = p.m_index0;
  s.index1 = p.m_index1;
  s.contact_point_flags = p.m_contactPointFlags;
  s.applied_impulse = p.m_appliedImpulse;
  s.prev_rhs = p.m_prevRHS;
  s.applied_impulse_lateral1 = p.m_appliedImpulseLateral1;
  s.applied_impulse_lateral2 = p.m_appliedImpulseLateral2;
  s.contact_motion1 = p.m_contactMotion1;
  s.contact_motion2 = p.m_contactMotion2;
  s.contact_cfm = p.m_contactCFM;
  s.combined_contact_stiffness1 = p.m_combinedContactStiffness1;
  s.contact_erp = p.m_contactERP;
  s.combined_contact_damping1 = p.m_combinedContactDamping1;
  s.friction_cfm = p.m_frictionCFM;
  s.lifetime = p.m_lifeTime;
  put3(s.lateral_friction_dir1, p.m_lateralFrictionDir1);
  put3(s.lateral_friction_dir2, p.m_lateralFrictionDir2);
  return s;
}

void from_state(const ContactPointState& s, btManifoldPoint& p) {
  p.m_localPointA = get3(s.local_point_a);
  p.m_localPointB = get3(s.local_point_b);
  p.m_positionWorldOnB = get3(s.position_world_on_b);
  p.m_positionWorldOnA = get3(s.position_world_on_a);
  p.m_normalWorldOnB = get3(s.normal_world_on_b);
  p.m_distance1 = s.distance;
  p.m_combinedFriction = s.combined_friction;
  p.m_combinedRollingFriction = s.combined_rolling_friction;
  p.m_combinedSpinningFriction = s.combined_spinning_friction;
  p.m_combinedRestitution = s.combined_restitution;
  p.m_partId0 = s.part_id0;
  p.m_partId1 = s.part_id1;
  p.m_index0 = s.index0;
  p.m_index1 = s.index1;
  p.m_userPersistentData = nullptr;
  p.m_contactPointFlags = s.contact_point_flags;
  p.m_appliedImpulse = s.applied_impulse;
  p.m_prevRHS = s.prev_rhs;
  p.m_appliedImpulseLateral1 = s.applied_impulse_lateral1;
  p.m_appliedImpulseLateral2 = s.applied_impulse_lateral2;
  p.m_contactMotion1 = s.contact_motion1;
  p.m_contactMotion2 = s.contact_motion2;
  // Unions in Bullet: write the members that share storage in the same order
  // as they were read, the second one wins (both were read from one storage).
  p.m_contactCFM = s.contact_cfm;
  p.m_combinedContactStiffness1 = s.combined_contact_stiffness1;
  p.m_contactERP = s.contact_erp;
  p.m_combinedContactDamping1 = s.combined_contact_damping1;
  p.m_frictionCFM = s.friction_cfm;
  p.m_lifeTime = s.lifetime;
  p.m_lateralFrictionDir1 = get3(s.lateral_friction_dir1);
  p.m_lateralFrictionDir2 = get3(s.lateral_friction_dir2);
}

}  // namespace

BodyDynamicState read_dynamic_state(const btRigidBody& body) {
  BodyDynamicState s;
  put_transform(s.basis, s.origin, body.getWorldTransform());
  put_transform(s.interpolation_basis, s.interpolation_origin, body.getInterpolationWorldTransform());
  put3(s.linear_velocity, body.getLinearVelocity());
  put3(s.angular_velocity, body.getAngularVelocity());
  put3(s.interpolation_linear_velocity, body.getInterpolationLinearVelocity());
  put3(s.interpolation_angular_velocity, body.getInterpolationAngularVelocity());
  s.activation_state = body.getActivationState();
  s.deactivation_time = body.getDeactivationTime();
  s.hit_fraction = body.getHitFraction();
  return s;
}

btTransform world_transform_of(const BodyDynamicState& s) {
  btTransform t;
  t.getBasis().setValue(s.basis[0], s.basis[1], s.basis[2], s.basis[3], s.basis[4], s.basis[5], s.basis[6],
                        s.basis[7], s.basis[8]);
  t.setOrigin(get3(s.origin));
  return t;
}

CanonicalWorld::CanonicalWorld(const WorldSnapshot& snapshot, const std::vector<std::size_t>& insertion_order) {
  build(snapshot.settings);
  steps_done_ = snapshot.steps_done;
  std::vector<std::size_t> order = insertion_order;
  if (order.empty()) {
    order.resize(snapshot.bodies.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
  }
  if (order.size() != snapshot.bodies.size())
    throw std::invalid_argument("CanonicalWorld: insertion order must list every body once");
  for (std::size_t i : order) {
    const BodySnapshot& b = snapshot.bodies.at(i);
    insert_body(b.description, &b.state);
  }
  std::sort(entries_.begin(), entries_.end(),
            [](const auto& a, const auto& b) { return a->description.id < b->description.id; });
  for (std::size_t i = 1; i < entries_.size(); ++i)
    if (entries_[i]->description.id == entries_[i - 1]->description.id)
      throw std::invalid_argument("CanonicalWorld: duplicate body id " +
                                  std::to_string(entries_[i]->description.id));
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
    auto* body0 = static_cast<btCollisionObject*>(pair->m_pProxy0->m_clientObject);
    auto* body1 = static_cast<btCollisionObject*>(pair->m_pProxy1->m_clientObject);
    // 3. the algorithm as btCollisionDispatcher::defaultNearCallback makes it.
    if (!pair->m_algorithm) {
      btCollisionObjectWrapper w0(nullptr, body0->getCollisionShape(), body0, body0->getWorldTransform(), -1, -1);
      btCollisionObjectWrapper w1(nullptr, body1->getCollisionShape(), body1, body1->getWorldTransform(), -1, -1);
      pair->m_algorithm = parts_->dispatcher.findAlgorithm(&w0, &w1, nullptr, BT_CONTACT_POINT_ALGORITHMS);
    }
    btManifoldArray owned;
    if (pair->m_algorithm) pair->m_algorithm->getAllContactManifolds(owned);
    if (owned.size() != 1)
      throw std::logic_error("CanonicalWorld: pair " + std::to_string(ms.id0) + "-" + std::to_string(ms.id1) +
                             " has " + std::to_string(owned.size()) + " manifolds, expected 1");
    btPersistentManifold& m = *owned[0];
    if (static_cast<BodyId>(m.getBody0()->getUserIndex()) != ms.id0 ||
        static_cast<BodyId>(m.getBody1()->getUserIndex()) != ms.id1)
      throw std::logic_error("CanonicalWorld: manifold body order differs from the snapshot's");
    m.clearManifold();
    m.setNumContacts(static_cast<int>(ms.points.size()));
    for (std::size_t i = 0; i < ms.points.size(); ++i) from_state(ms.points[i], m.getContactPoint(static_cast<int>(i)));
  }
}

std::vector<ManifoldState> CanonicalWorld::contact_state() const {
  std::vector<ManifoldState> out;
  btDispatcher& dispatcher = parts_->dispatcher;
  for (int i = 0; i < dispatcher.getNumManifolds(); ++i) {
    const btPersistentManifold* m = dispatcher.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    ManifoldState ms;
    ms.id0 = static_cast<BodyId>(m->getBody0()->getUserIndex());
    ms.id1 = static_cast<BodyId>(m->getBody1()->getUserIndex());
    for (int p = 0; p < m->getNumContacts(); ++p) ms.points.push_back(to_state(m->getContactPoint(p)));
    out.push_back(std::move(ms));
  }
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
  return s;
}

}  // namespace soda
