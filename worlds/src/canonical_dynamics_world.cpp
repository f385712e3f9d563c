#include "canonical_dynamics_world.h"

#include "soda/worlds/bullet_bodies.h"

#include "body_factory.h"
#include "island_solver_settings.h"
#include "island_substeps.h"
#include "joint_factory.h"
#include "parallel_stages.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/solver_pool.h"
#include "speculative_contact.h"
#include "parking.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>

#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>

namespace soda {
namespace {

// Bullet's dbvt never rebalances while proxies are only inserted (stepping
// rebalances it a little per step), so building a world in spatial order
// made it deep (cube-pile: depth 71 at 10,000 proxies, 208 at 100,000, 408
// at 400,000) and each insertion's overlap query slow. It is rebuilt top
// down whenever its leaf count reaches a power of two from this one on:
// O(N log N) in all, depth 16..23. Threshold 2 (pure top-down split):
// Bullet's default (bottom-up below 128 leaves) cost 4x more.
constexpr int kRebalanceFromLeaves = 4096;
constexpr int kTopDownThreshold = 2;

}  // namespace

void add_body_with_canonical_proxy(btDiscreteDynamicsWorld& world, btDbvtBroadphase& broadphase,
                                   btRigidBody* body, int group, int mask) {
  // btDbvtBroadphase::createProxy numbers proxies with ++m_gid; pair caches
  // order a pair's proxies by that number (body0 = smaller).
  broadphase.m_gid = body->getUserIndex();
  world.addRigidBody(body, group, mask);
  rebalance_after_insertion(broadphase);
}

void rebalance_after_insertion(btDbvtBroadphase& broadphase) {
  // The tree's shape decides only the order in which overlaps are found,
  // never which (pairs are canonical: remove_stale_pairs, sorted islands).
  btDbvt& tree = broadphase.m_sets[0];
  const int leaves = tree.m_leaves;
  if (leaves >= kRebalanceFromLeaves && (leaves & (leaves - 1)) == 0) tree.optimizeTopDown(kTopDownThreshold);
}

std::size_t remove_stale_pairs(btDbvtBroadphase& broadphase, btDispatcher* dispatcher) {
  btOverlappingPairCache* cache = broadphase.getOverlappingPairCache();
  btBroadphasePairArray& pairs = cache->getOverlappingPairArray();
  for (int i = 0; i < pairs.size();) {
    auto* a = static_cast<btDbvtProxy*>(pairs[i].m_pProxy0);
    auto* b = static_cast<btDbvtProxy*>(pairs[i].m_pProxy1);
    if (Intersect(a->leaf->volume, b->leaf->volume)) {
      ++i;
    } else {
      cache->removeOverlappingPair(a, b, dispatcher);  // moves the last pair to i
    }
  }
  return static_cast<std::size_t>(pairs.size());
}

bool decide_island_sleeping(btCollisionObject* const* bodies, int count) {
  bool all_sleeping = true;
  for (int j = 0; j < count; ++j) {
    const int s = bodies[j]->getActivationState();
    if (s == ACTIVE_TAG || s == DISABLE_DEACTIVATION) {
      all_sleeping = false;
      break;
    }
  }
  for (int j = 0; j < count; ++j) {
    btCollisionObject* body = bodies[j];
    if (all_sleeping) {
      body->setActivationState(ISLAND_SLEEPING);
    } else if (body->getActivationState() == ISLAND_SLEEPING) {
      body->setActivationState(WANTS_DEACTIVATION);
      body->setDeactivationTime(btScalar(0));
    }
  }
  return !all_sleeping;
}

bool kinematic_wakes(btCollisionObject* a, btCollisionObject* b) {
  if (a->getActivationState() == ISLAND_SLEEPING && b->getActivationState() == ISLAND_SLEEPING) return false;
  bool woke = false;
  if (a->isKinematicObject() && a->getActivationState() != ISLAND_SLEEPING && a->hasContactResponse())
    b->activate(), woke = true;
  if (b->isKinematicObject() && b->getActivationState() != ISLAND_SLEEPING && b->hasContactResponse())
    a->activate(), woke = true;
  return woke;
}

bool wake_touched_by_kinematic(bool awake, btCollisionObject* const* bodies, int count,
                               btPersistentManifold* const* manifolds, int manifold_count) {
  bool woke = false;
  for (int i = 0; i < manifold_count; ++i) {
    const btPersistentManifold* m = manifolds[i];
    if (m->getNumContacts() == 0) continue;
    woke = kinematic_wakes(const_cast<btCollisionObject*>(m->getBody0()), const_cast<btCollisionObject*>(m->getBody1())) ||
           woke;
  }
  if (awake || !woke) return awake;
  for (int j = 0; j < count; ++j)
    if (bodies[j]->isActive()) return true;
  return false;
}

CanonicalDynamicsWorld::CanonicalDynamicsWorld(btDispatcher* dispatcher, btDbvtBroadphase* broadphase,
                                               ColouredSolver* solver, btCollisionConfiguration* config)
    : DetachableWorld(dispatcher, broadphase, solver, config), broadphase_(broadphase), solver_(solver) {
  // Islands are never batched: one solveGroup per island (see header).
  getSolverInfo().m_minimumSolverBatchSize = 1;
}

void CanonicalDynamicsWorld::add_body(btRigidBody* body, int group, int mask) {
  add_body_with_canonical_proxy(*this, *broadphase_, body, group, mask);
  if (!body->isStaticOrKinematicObject()) {
    if (bodies_sorted_) sorted_count_ = dynamic_bodies_.size();
    dynamic_bodies_.push_back(body);
    bodies_sorted_ = false;
  } else {
    body->setIslandTag(-1);
    if (body->isKinematicObject()) kinematic_bodies_.push_back(body);
  }
}

void CanonicalDynamicsWorld::add_joint(btTypedConstraint* constraint, bool collide_connected) {
  addConstraint(constraint, !collide_connected);
  ++jointed_[&constraint->getRigidBodyA()];
  ++jointed_[&constraint->getRigidBodyB()];
}

// Bodies added since the last sort (parked islands woken, parking.h) are
// sorted alone and merged into the sorted ones: O(world bodies) per step
// instead of a sort of them all (ids are unique: the same order).
void CanonicalDynamicsWorld::sort_dynamic_bodies() {
  const auto by_id = [](const btRigidBody* a, const btRigidBody* b) { return id_of(a) < id_of(b); };
  const auto middle = dynamic_bodies_.begin() + static_cast<std::ptrdiff_t>(sorted_count_);
  std::sort(middle, dynamic_bodies_.end(), by_id);
  std::inplace_merge(dynamic_bodies_.begin(), middle, dynamic_bodies_.end(), by_id);
  for (std::size_t i = 0; i < dynamic_bodies_.size(); ++i)
    dynamic_bodies_[i]->setUserIndex2(static_cast<int>(i));
  bodies_sorted_ = true;
}

// Stock btDbvtBroadphase removes stale pairs (leaf volumes no longer
// overlapping) a fraction (m_cupdates %) per step; remove all of them, every
// step, so the pair set is a function of the leaf volumes alone.
// With parking (parking.h), the wake rule around Bullet's pass: parked
// islands an active body touches come back before it, their contact state
// after it.
void CanonicalDynamicsWorld::computeOverlappingPairs() {
  if (parking_ && parking_->parked_islands() > 0) {
    if (gDisableDeactivation) {
      parking_->touch_all();
    } else {
      for (btRigidBody* b : dynamic_bodies_) {
        if (!b->isActive()) continue;
        const btBroadphaseProxy* p = b->getBroadphaseHandle();
        parking_->touch(p->m_aabbMin, p->m_aabbMax);
      }
      for (btRigidBody* b : kinematic_bodies_) {
        if (!b->isActive()) continue;  // active in the steps it moves
        if (kinematic_teleported(*b)) {
          parking_->touch_all();
          break;
        }
        btVector3 lo, hi;
        kinematic_touch_box(*b, getDispatchInfo().m_timeStep, lo, hi);
        parking_->touch(lo, hi);
      }
    }
    parking_->wake_touched();
  }
  btCollisionWorld::computeOverlappingPairs();
  stats_.broadphase_pairs = remove_stale_pairs(*broadphase_, m_dispatcher1);
  if (parking_) parking_->restore_woken_contacts();
}

void CanonicalDynamicsWorld::forget_detached_bodies() {
  compact_detached_bodies();
  std::size_t d = 0, sorted_kept = 0;
  for (std::size_t i = 0; i < dynamic_bodies_.size(); ++i) {
    btRigidBody* b = dynamic_bodies_[i];
    if (!b->getBroadphaseHandle()) continue;
    dynamic_bodies_[d++] = b;
    if (i < sorted_count_) ++sorted_kept;
  }
  dynamic_bodies_.resize(d);
  sorted_count_ = sorted_kept;  // the order is kept: the sorted prefix stays one
  if (bodies_sorted_)
    for (std::size_t i = 0; i < d; ++i) dynamic_bodies_[i]->setUserIndex2(static_cast<int>(i));
}

// As btCollisionWorld::performDiscreteCollisionDetection (the dispatch:
// dispatch_pairs), then the speculative points.
void CanonicalDynamicsWorld::performDiscreteCollisionDetection() {
  updateAabbs();
  computeOverlappingPairs();
  dispatch_pairs();
  // Each pair's point is a function of its two bodies alone: the pairs' order
  // does not matter.
  speculative_.clear();
  if (bullet_defaults_) {
    stats_.speculative_contacts = 0;
    return;
  }
  btBroadphasePairArray& pairs = broadphase_->getOverlappingPairCache()->getOverlappingPairArray();
  btManifoldArray manifolds;
  for (int i = 0; i < pairs.size(); ++i) {
    const btBroadphasePair& pair = pairs[i];
    if (!pair.m_algorithm) continue;
    const auto* obj0 = static_cast<const btCollisionObject*>(pair.m_pProxy0->m_clientObject);
    const auto* obj1 = static_cast<const btCollisionObject*>(pair.m_pProxy1->m_clientObject);
    if (!is_fast(*obj0) && !is_fast(*obj1)) continue;
    // As the near callback (here and in the territory world): pairs it skipped get none.
    if (!m_dispatcher1->needsCollision(obj0, obj1)) continue;
    manifolds.resize(0);
    pair.m_algorithm->getAllContactManifolds(manifolds);
    if (manifolds.size() == 1 && add_speculative_contact(*manifolds[0])) speculative_.push_back(manifolds[0]);
  }
  stats_.speculative_contacts = speculative_.size();
}

void CanonicalDynamicsWorld::integrateTransforms(btScalar time_step) {
  for (btPersistentManifold* m : speculative_) clear_speculative_contact(*m);
  speculative_.clear();
  integrate_bodies(time_step);
}

// Step 1 and 2: islands from manifolds that hold points (island_builder.h).
void CanonicalDynamicsWorld::build_islands() {
  const int n = static_cast<int>(dynamic_bodies_.size());
  islands_.reset(n);
  contact_manifolds_.clear();
  btDispatcher* dispatcher = getDispatcher();
  const int num_manifolds = dispatcher->getNumManifolds();
  for (int i = 0; i < num_manifolds; ++i) {
    btPersistentManifold* m = dispatcher->getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    contact_manifolds_.push_back(m);
    const btCollisionObject* a = m->getBody0();
    const btCollisionObject* b = m->getBody1();
    if (a->mergesSimulationIslands() && b->mergesSimulationIslands())
      islands_.join(a->getUserIndex2(), b->getUserIndex2());  // positions: id order
  }
  stats_.contact_manifolds = contact_manifolds_.size();
  // Joints that hold: an edge like a manifold with points.
  for (int i = 0; i < m_constraints.size(); ++i) {
    const btTypedConstraint* c = m_constraints[i];
    if (!c->isEnabled()) continue;
    const btRigidBody& a = c->getRigidBodyA();
    const btRigidBody& b = c->getRigidBodyB();
    if (a.isStaticOrKinematicObject() || b.isStaticOrKinematicObject()) continue;
    islands_.join(a.getUserIndex2(), b.getUserIndex2());
  }
  islands_.finish();
  island_bodies_.resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) {
    btRigidBody* body = dynamic_bodies_[static_cast<std::size_t>(islands_.order()[static_cast<std::size_t>(i)])];
    body->setIslandTag(islands_.island_of(body->getUserIndex2()));
    body->setCompanionId(-1);
    island_bodies_[static_cast<std::size_t>(i)] = body;
  }
  stats_.islands = static_cast<std::size_t>(islands_.island_count());
}

// Step 3: as btSimulationIslandManager::buildIslands.
void CanonicalDynamicsWorld::decide_sleeping() {
  for (int k = 0; k < islands_.island_count(); ++k)
    decide_island_sleeping(&island_bodies_[static_cast<std::size_t>(islands_.begin(k))], islands_.size(k));
}

// Step 4a: as the manifold loop of buildIslands, then a canonical order.
void CanonicalDynamicsWorld::collect_island_manifolds() {
  island_manifolds_.clear();
  btDispatcher* dispatcher = getDispatcher();
  for (btPersistentManifold* m : contact_manifolds_) {
    auto* a = const_cast<btCollisionObject*>(m->getBody0());
    auto* b = const_cast<btCollisionObject*>(m->getBody1());
    if (a->getActivationState() == ISLAND_SLEEPING && b->getActivationState() == ISLAND_SLEEPING)
      continue;
    kinematic_wakes(a, b);
    if (!dispatcher->needsResponse(a, b)) continue;
    const int island = a->getIslandTag() >= 0 ? a->getIslandTag() : b->getIslandTag();
    if (island < 0) continue;
    island_manifolds_.add(island, {id_of(a), id_of(b)}, m);
  }
  island_manifolds_.finish(islands_.island_count());
  if (island_manifolds_.first_duplicate() >= 0)
    throw std::logic_error("CanonicalWorld: two manifolds for one pair (compound shapes are not supported)");
  island_joints_.clear();
  if (m_constraints.size() == 0) return;  // a world without joints pays nothing more
  for (int i = 0; i < m_constraints.size(); ++i) {
    btTypedConstraint* c = m_constraints[i];
    if (!c->isEnabled()) continue;
    const btRigidBody& a = c->getRigidBodyA();
    const btRigidBody& b = c->getRigidBodyB();
    const int island = a.getIslandTag() >= 0 ? a.getIslandTag() : b.getIslandTag();
    if (island < 0) continue;
    island_joints_.add(island, joint_id_of(c), c);
  }
  island_joints_.finish(islands_.island_count());
}

// Step 4b: one solveGroup per awake island.
// Islands are disjoint, and an island's solve is a pure function of its
// contents (DESIGN.md §2): they may be solved in any order, by any solver.
// With a pool, the small islands (fewer contact points than the coloured
// solve's threshold, so Bullet's own loop on one thread) are solved side by
// side on the pool's threads, each task with a solver of its own; the large
// ones, which share the pool inside their solve, one after the other here.
// An island touching a kinematic body stays here too: Bullet (built without
// BT_THREADSAFE) writes a kinematic body's companion id while solving.
void CanonicalDynamicsWorld::solve_islands(btContactSolverInfo& solver_info) {
  const int islands = islands_.island_count();
  btDispatcher* dispatcher = getDispatcher();
  SolverPool* pool = stage_pool();
  lone_bodies_.clear();
  big_islands_.clear();
  small_islands_.clear();
  stats_.awake_islands = stats_.sleeping_islands = stats_.solved_manifolds = stats_.substepped_islands = 0;
  stats_.solved_joints = 0;
  stats_.substep_threads = 0;
  stats_.island_threads = 1;
  for (int k = 0; k < islands; ++k) {
    const std::size_t m_begin = static_cast<std::size_t>(island_manifolds_.begin(k));
    const std::size_t m = static_cast<std::size_t>(island_manifolds_.begin(k + 1));
    const int body_begin = islands_.begin(k);
    const int body_count = islands_.size(k);
    bool awake = false;
    for (int j = body_begin; j < body_begin + body_count && !awake; ++j)
      awake = island_bodies_[static_cast<std::size_t>(j)]->isActive();
    if (!awake) {
      ++stats_.sleeping_islands;
      continue;
    }
    ++stats_.awake_islands;
    const int manifold_count = static_cast<int>(m - m_begin);
    // Without joints island_joints_ is not built this step (collect_island_manifolds
    // returns before it): its begin() and count() are not to be read.
    const bool jointed = m_constraints.size() != 0;
    const int joint_count = jointed ? island_joints_.count(k) : 0;
    if (body_count == 1 && manifold_count == 0 && joint_count == 0) {
      lone_bodies_.push_back(island_bodies_[body_begin]);
      continue;
    }
    stats_.solved_manifolds += static_cast<std::size_t>(manifold_count);
    stats_.solved_joints += static_cast<std::size_t>(joint_count);
    const IslandJob job{body_begin, body_count, m_begin, manifold_count, jointed ? island_joints_.begin(k) : 0,
                        joint_count};
    bool small = pool != nullptr;
    int points = 0;
    for (std::size_t i = m_begin; i < m && small; ++i) {
      const btPersistentManifold& pm = *island_manifolds_.values()[i];
      points += pm.getNumContacts();
      small = points < kColouredMinContactRows && !pm.getBody0()->isKinematicObject() &&
              !pm.getBody1()->isKinematicObject();
    }
    (small ? small_islands_ : big_islands_).push_back(job);
  }

  std::atomic<int> substepped{0};
  std::atomic<bool> small_substepped{false};
  auto solve = [&](btConstraintSolver& solver, const IslandJob& job, btContactSolverInfo& scratch,
                   SolverPool* island_pool) {
    btCollisionObject** bodies = &island_bodies_[static_cast<std::size_t>(job.body_begin)];
    btPersistentManifold** manifolds =
        job.manifold_count ? island_manifolds_.data() + job.manifold_begin : nullptr;
    btTypedConstraint** joints = job.joint_count ? island_joints_.data() + job.joint_begin : nullptr;
    int substeps = 1;
    const btContactSolverInfo& info =
        bullet_defaults_ ? solver_info
                         : island_solver_info(solver_info, scratch, bodies, job.body_count, manifolds,
                                              job.manifold_count, joints, job.joint_count, substeps);
    if (substeps > 1) substepped.fetch_add(1, std::memory_order_relaxed);
    return solve_island(solver, bodies, job.body_count, manifolds, job.manifold_count, info, substeps, *dispatcher,
                        island_pool, joints, job.joint_count);
  };
  if (!small_islands_.empty()) {
    const std::size_t threads = static_cast<std::size_t>(pool->threads());
    if (spare_solvers_.size() < threads) {
      spare_taken_ = std::make_unique<std::atomic<bool>[]>(threads);
      for (std::size_t i = 0; i < threads; ++i) spare_taken_[i].store(false);
      while (spare_solvers_.size() < threads) spare_solvers_.push_back(std::make_unique<ColouredSolver>());
    }
    for (auto& s : spare_solvers_) s->set_mode(solver_->mode());
    stats_.island_threads = run_in_chunks(
        pool, static_cast<int>(small_islands_.size()), kParallelMinIslands, kIslandsPerTask, [&](int begin, int end) {
          std::size_t taken = 0;
          while (spare_taken_[taken].exchange(true, std::memory_order_acquire)) taken = (taken + 1) % threads;
          btContactSolverInfo scratch;
          for (int i = begin; i < end; ++i)
            if (solve(*spare_solvers_[taken], small_islands_[static_cast<std::size_t>(i)], scratch, nullptr) > 0)
              small_substepped.store(true, std::memory_order_relaxed);  // on this task's thread only
          spare_taken_[taken].store(false, std::memory_order_release);
        });
  }
  for (const IslandJob& job : big_islands_)
    stats_.substep_threads = std::max(stats_.substep_threads, solve(*solver_, job, island_info_, pool));
  if (small_substepped.load()) stats_.substep_threads = std::max(stats_.substep_threads, 1);
  stats_.substepped_islands = static_cast<std::size_t>(substepped.load());
  stats_.lone_bodies = lone_bodies_.size();
  if (!lone_bodies_.empty())
    solver_->solveGroup(lone_bodies_.data(), static_cast<int>(lone_bodies_.size()), nullptr, 0, nullptr, 0,
                        solver_info, getDebugDrawer(), dispatcher);
}

// Coloured solves of the world's solver and of the spare ones: an island
// small at the step's start may grow past kColouredMinContactRows in its
// second substep on a spare solver, and counts as on one thread.
std::size_t CanonicalDynamicsWorld::coloured_so_far() const {
  std::size_t n = solver_->stats().coloured_islands;
  for (const auto& s : spare_solvers_) n += s->stats().coloured_islands;
  return n;
}

void CanonicalDynamicsWorld::solveConstraints(btContactSolverInfo& solver_info) {
  if (!bodies_sorted_) sort_dynamic_bodies();
  getConstraintSolver()->prepareSolve(getNumCollisionObjects(), getDispatcher()->getNumManifolds());
  const std::size_t coloured_before = coloured_so_far();
  build_islands();
  decide_sleeping();
  collect_island_manifolds();
  solve_islands(solver_info);
  stats_.coloured_islands = coloured_so_far() - coloured_before;
  stats_.solver_threads = solver_->stats().threads_max;
  getConstraintSolver()->allSolved(solver_info, getDebugDrawer());
}

}  // namespace soda
