// BorderIslandSolver (border_island_solver.h): a merged island solved from
// its fragments, in four passes — gather (fragments to bodies by id and
// manifolds by key, own fragments taken), bodies (originals or copies in the
// state their owners sent), the solve (manifold copies, held manifolds
// pointed at the island's bodies), the result.
#include "border_island_solver.h"

#include <algorithm>
#include <stdexcept>
#include <string>

#include "body_factory.h"
#include "canonical_dynamics_world.h"
#include "contact_threshold.h"
#include "island_solver_settings.h"
#include "island_substeps.h"
#include "joint_factory.h"
#include "parallel_stages.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/value_codec.h"
#include "soda/worlds/territory_world.h"
#include "speculative_contact.h"

namespace soda {
namespace {

// Held manifolds pointed at the island's bodies get their own bodies back
// however the solve ends (invariant 2).
struct Redirected {
  btPersistentManifold* manifold;
  const btCollisionObject* body0;
  const btCollisionObject* body1;
};
struct RestoreEnds {
  std::vector<Redirected>& list;
  ~RestoreEnds() {
    for (const Redirected& r : list) r.manifold->setBodies(r.body0, r.body1);
  }
};

BodyResult body_result(BodyId id, const btRigidBody& c) {
  BodyResult r;
  r.id = id;
  const btTransform& t = c.getWorldTransform();
  for (int k = 0; k < 3; ++k) {
    r.linear_velocity[k] = c.getLinearVelocity()[k];
    r.angular_velocity[k] = c.getAngularVelocity()[k];
    r.origin[k] = t.getOrigin()[k];
    for (int j = 0; j < 3; ++j) r.basis[k * 3 + j] = t.getBasis()[k][j];
  }
  r.activation_state = c.getActivationState();
  r.deactivation_time = c.getDeactivationTime();
  return r;
}

}  // namespace

void BorderIslandSolver::Gathered::fail(const std::string& what) const {
  throw PartitionError("world " + std::to_string(world) + ", step " + std::to_string(step) +
                       ", border island of body " + (ids.empty() ? std::string("?") : std::to_string(ids[0])) + ": " +
                       what);
}

void BorderIslandSolver::begin_fragments() {
  held_by_key_.clear();
  own_fragments_.clear();
  solved_in_place_.clear();
}

void BorderIslandSolver::end_fragments() {
  std::sort(held_by_key_.begin(), held_by_key_.end());
  for (std::size_t i = 1; i < held_by_key_.size(); ++i)
    if (held_by_key_[i].first == held_by_key_[i - 1].first)
      throw std::logic_error("world " + std::to_string(world_) + ": two held manifolds of pair " +
                             std::to_string(held_by_key_[i].first.first) + "-" +
                             std::to_string(held_by_key_[i].first.second));
}

void BorderIslandSolver::end_step() {
  held_by_key_.clear();
  own_fragments_.clear();
  solved_in_place_.clear();
}

// The component of `f` if it is one of this step's own fragments not yet
// solved in place (and marks it taken), else -1 (invariant 3).
int BorderIslandSolver::take_own_fragment(const Fragment& f) {
  if (f.world != world_) return -1;
  auto it = std::find_if(own_fragments_.begin(), own_fragments_.end(),
                         [&](const std::pair<BodyId, int>& o) { return o.first == f.root; });
  if (it == own_fragments_.end()) return -1;
  const int component = it->second;
  own_fragments_.erase(it);
  int held = 0;
  btPersistentManifold* const* manifolds = host_.component_manifolds(component, held);
  bool same = f.manifolds.size() == static_cast<std::size_t>(held);
  for (int i = 0; same && i < held; ++i)
    same = id_of(manifolds[i]->getBody0()) == f.manifolds[static_cast<std::size_t>(i)].id0 &&
           id_of(manifolds[i]->getBody1()) == f.manifolds[static_cast<std::size_t>(i)].id1;
  if (!same)
    throw std::logic_error("world " + std::to_string(world_) + ": fragment " + std::to_string(f.root) +
                           " is not the one this world made of its component");
  return component;
}

// Gather: bodies by id, manifolds by key; an own fragment's bodies are its
// component's owned bodies, in order, and its manifolds the held ones.
void BorderIslandSolver::gather(const std::vector<const Fragment*>& island, std::int64_t step, Gathered& g) {
  for (const Fragment* f : island) {
    const int component = take_own_fragment(*f);
    int count = 0, held = 0;
    btCollisionObject* const* objects = component >= 0 ? host_.component_bodies(component, count) : nullptr;
    btPersistentManifold* const* held_ptrs = component >= 0 ? host_.component_manifolds(component, held) : nullptr;
    int next = 0;
    for (const BodyRecord& r : f->bodies) {
      btRigidBody* original = nullptr;
      if (component >= 0) {
        while (next < count && !host_.owns_body(objects[next])) ++next;
        if (next == count || id_of(objects[next]) != r.body.description.id)
          throw std::logic_error("world " + std::to_string(world_) + ": body " +
                                 std::to_string(r.body.description.id) + " of its own fragment is not its own");
        original = btRigidBody::upcast(objects[next++]);
      }
      g.bodies.push_back(IslandBody{r.body.description.id, &r, original});
    }
    for (std::size_t i = 0; i < f->manifolds.size(); ++i) {
      const ManifoldState& m = f->manifolds[i];
      g.manifolds.push_back(IslandManifold{{m.id0, m.id1}, &m, component >= 0 ? held_ptrs[i] : nullptr});
    }
    for (const Joint& j : f->joints) {
      btTypedConstraint* original = component >= 0 ? host_.held_joint(j.id) : nullptr;
      if (component >= 0 && !original)
        throw std::logic_error("world " + std::to_string(world_) + ": joint " + std::to_string(j.id) +
                               " of its own fragment is not held here");
      g.joints.push_back(IslandJoint{&j, original});
    }
    if (f->world == world_) (component >= 0 ? g.any_in_place : g.copied_own) = true;
  }
  std::sort(g.bodies.begin(), g.bodies.end(), [](const IslandBody& a, const IslandBody& b) { return a.id < b.id; });
  std::sort(g.manifolds.begin(), g.manifolds.end(),
            [](const IslandManifold& a, const IslandManifold& b) { return a.key < b.key; });
  g.ids.resize(g.bodies.size());
  for (std::size_t i = 0; i < g.bodies.size(); ++i) g.ids[i] = g.bodies[i].id;
  g.world = world_;
  g.step = step;
  if (g.bodies.empty()) g.fail("no bodies");
  for (std::size_t i = 1; i < g.ids.size(); ++i)
    if (g.ids[i] == g.ids[i - 1]) g.fail("body " + std::to_string(g.ids[i]) + " has two owners");
  std::sort(g.joints.begin(), g.joints.end(),
            [](const IslandJoint& a, const IslandJoint& b) { return a.description->id < b.description->id; });
  for (std::size_t i = 1; i < g.joints.size(); ++i)
    if (g.joints[i].description->id == g.joints[i - 1].description->id)
      g.fail("joint " + std::to_string(g.joints[i].description->id) + " has two holders");
  for (std::size_t i = 1; i < g.manifolds.size(); ++i)
    if (g.manifolds[i].key == g.manifolds[i - 1].key)
      g.fail("pair " + std::to_string(g.manifolds[i].key.first) + "-" + std::to_string(g.manifolds[i].key.second) +
             " has two holders");
}

// The other worlds' bodies: copies, in the state their owners sent. Made
// here (the map of copies is this thread's), filled on the solver pool: each
// item writes only its own copy, so any split gives the same bits. This
// world's own bodies are in that state already (the fragment read it).
void BorderIslandSolver::place_bodies(const Gathered& g, SolverPool* pool, std::vector<btCollisionObject*>& bodies) {
  bodies.resize(g.bodies.size());
  for (std::size_t i = 0; i < g.bodies.size(); ++i) {
    if (g.bodies[i].original) {
      bodies[i] = g.bodies[i].original;
      continue;
    }
    const BodySnapshot& b = g.bodies[i].record->body;
    std::unique_ptr<Copy>& c = copies_[b.description.id];
    if (!c) {
      c = std::make_unique<Copy>();
      c->shape = make_collision_shape(b.description.shape);
      c->body = make_body_from_state(b.description, *c->shape, b.state);
      c->body->setUserIndex(static_cast<int>(b.description.id));
      c->description = b.description;
    } else if (!same_material(c->description, b.description)) {  // an input changed it at its owner
      c->description = b.description;
      apply_material(*c->body, b.description, btVector3(0, 0, 0));  // a copy is in no world: no gravity
    }
    bodies[i] = c->body.get();
  }
  run_in_chunks(pool, static_cast<int>(bodies.size()), kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      btRigidBody& rb = *btRigidBody::upcast(bodies[static_cast<std::size_t>(i)]);
      rb.setCompanionId(-1);
      if (g.bodies[static_cast<std::size_t>(i)].original) continue;
      const BodyRecord& r = *g.bodies[static_cast<std::size_t>(i)].record;
      write_dynamic_state(rb, r.body.state);
      rb.clearForces();
      rb.applyCentralForce(btVector3(r.total_force[0], r.total_force[1], r.total_force[2]));
      rb.applyTorque(btVector3(r.total_torque[0], r.total_torque[1], r.total_torque[2]));
    }
  });
}

// An awake island: the other worlds' manifolds are copies, each reset to
// what CappedDispatcher::getNewManifold makes (thresholds as it gives them),
// then the points. A manifold held here is solved in place; one with
// a ghost at an end points at the copy of that body meanwhile (the ghost is
// this world's view of another world's body, not the island's).
void BorderIslandSolver::solve_awake(const Gathered& g, std::vector<btCollisionObject*>& bodies,
                                     const BorderIslandTools& tools, IslandResult& result,
                                     TerritoryCounters& counters) {
  auto object_of = [&](BodyId id) -> btCollisionObject* {
    auto it = std::lower_bound(g.ids.begin(), g.ids.end(), id);
    if (it != g.ids.end() && *it == id) return bodies[static_cast<std::size_t>(it - g.ids.begin())];
    btCollisionObject* s = host_.static_body(id);
    if (!s) g.fail("manifold refers to body " + std::to_string(id) + ", which is neither in the island nor static");
    return s;
  };
  const int manifold_count = static_cast<int>(g.manifolds.size());
  std::vector<btPersistentManifold*> ptrs(g.manifolds.size());
  std::vector<std::pair<btCollisionObject*, btCollisionObject*>> ends(g.manifolds.size());
  std::size_t copy_count = 0;
  for (std::size_t i = 0; i < g.manifolds.size(); ++i) {  // here: object_of may throw
    ends[i] = {object_of(g.manifolds[i].key.first), object_of(g.manifolds[i].key.second)};
    if (g.manifolds[i].original) {
      ptrs[i] = g.manifolds[i].original;
      continue;
    }
    if (copy_count == manifold_copies_.size())
      manifold_copies_.push_back(std::make_unique<btPersistentManifold>(nullptr, nullptr, 0, btScalar(0), btScalar(0)));
    ptrs[i] = manifold_copies_[copy_count++].get();
  }
  std::vector<Redirected> redirected;
  for (std::size_t i = 0; i < g.manifolds.size(); ++i) {
    btPersistentManifold* m = g.manifolds[i].original;
    if (m && (m->getBody0() != ends[i].first || m->getBody1() != ends[i].second)) {
      redirected.push_back(Redirected{m, m->getBody0(), m->getBody1()});
      m->setBodies(ends[i].first, ends[i].second);
    }
  }
  RestoreEnds restore{redirected};
  SolverPool* pool = tools.pool;
  run_in_chunks(pool, manifold_count, kParallelMinPairs, kPairsPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      if (g.manifolds[static_cast<std::size_t>(i)].original) continue;
      const auto [b0, b1] = ends[static_cast<std::size_t>(i)];
      const btScalar breaking = manifold_breaking_threshold(*b0, *b1);
      const btScalar processing = btMin(b0->getContactProcessingThreshold(), b1->getContactProcessingThreshold());
      btPersistentManifold& m = *ptrs[static_cast<std::size_t>(i)];
      m = btPersistentManifold(b0, b1, 0, breaking, processing);
      write_manifold_points(*g.manifolds[static_cast<std::size_t>(i)].state, m);
    }
  });
  btPersistentManifold** manifold_ptrs = ptrs.empty() ? nullptr : ptrs.data();
  const int body_count = static_cast<int>(bodies.size());
  // Joints: this world's own in place, the others built on the island's
  // bodies (copies or originals) and statics.
  std::vector<btTypedConstraint*> joints(g.joints.size());
  std::vector<std::unique_ptr<btTypedConstraint>> joint_copies;
  for (std::size_t i = 0; i < g.joints.size(); ++i) {
    if (g.joints[i].original) {
      joints[i] = g.joints[i].original;
      continue;
    }
    const Joint& j = *g.joints[i].description;
    btRigidBody* a = btRigidBody::upcast(object_of(j.body_a));
    btRigidBody* b = btRigidBody::upcast(object_of(j.body_b));
    if (!a || !b) g.fail("joint " + std::to_string(j.id) + " joins a body that is not a rigid body");
    joint_copies.push_back(make_constraint(j, *a, *b));
    joints[i] = joint_copies.back().get();
  }
  btTypedConstraint** joint_ptrs = joints.empty() ? nullptr : joints.data();
  const int joint_count = static_cast<int>(joints.size());
  int substeps = 1;
  const btContactSolverInfo& info = island_solver_info(tools.info, tools.island_info, bodies.data(), body_count,
                                                       manifold_ptrs, manifold_count, joint_ptrs, joint_count,
                                                       substeps);
  if (substeps > 1) ++counters.substepped_islands;
  solve_island(tools.solver, bodies.data(), body_count, manifold_ptrs, manifold_count, info, substeps,
               tools.dispatcher, pool, joint_ptrs, joint_count);
  for (std::size_t i = 0; i < joints.size(); ++i)
    if (!joints[i]->isEnabled()) result.broken_joints.push_back(g.joints[i].description->id);
  counters.merged_island_joints += joints.size();
  counters.merged_island_joints_in_place += joints.size() - joint_copies.size();
  run_in_chunks(pool, manifold_count, kParallelMinPairs, kPairsPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i)
      read_manifold_state(*ptrs[static_cast<std::size_t>(i)], result.manifolds[static_cast<std::size_t>(i)]);
  });
}

IslandResult BorderIslandSolver::solve(const std::vector<const Fragment*>& island, const BorderIslandTools& tools,
                                       std::int64_t step, TerritoryCounters& counters) {
  Gathered g;
  gather(island, step, g);
  // The island's part here is solved in place: apply() leaves it (if a part
  // of it was solved on copies, writing the rest again is harmless).
  if (g.any_in_place && !g.copied_own) solved_in_place_.push_back(g.ids.front());
  std::vector<btCollisionObject*> bodies;
  place_bodies(g, tools.pool, bodies);
  IslandResult result;
  result.island = g.ids.front();
  result.manifolds.resize(g.manifolds.size());
  bool awake = decide_island_sleeping(bodies.data(), static_cast<int>(bodies.size()));
  // A moving kinematic body (a static here) wakes what it touches, as in the
  // canonical world (wake_touched_by_kinematic).
  bool woke = false;
  for (const auto& m : g.manifolds) {
    btCollisionObject* s0 = host_.static_body(m.key.first);
    btCollisionObject* s1 = host_.static_body(m.key.second);
    if (!s0 == !s1) continue;  // two dynamic bodies (or, never, two statics)
    const BodyId other = s0 ? m.key.second : m.key.first;
    auto it = std::lower_bound(g.ids.begin(), g.ids.end(), other);
    if (it == g.ids.end() || *it != other) continue;
    btCollisionObject* body = bodies[static_cast<std::size_t>(it - g.ids.begin())];
    woke = (s0 ? kinematic_wakes(s0, body) : kinematic_wakes(body, s1)) || woke;
  }
  if (!awake && woke)
    for (btCollisionObject* b : bodies) awake = awake || b->isActive();
  if (awake) {
    solve_awake(g, bodies, tools, result, counters);
  } else {
    run_in_chunks(tools.pool, static_cast<int>(g.manifolds.size()), kParallelMinPairs, kPairsPerTask,
                  [&](int begin, int end) {
                    for (int i = begin; i < end; ++i)
                      result.manifolds[static_cast<std::size_t>(i)] = *g.manifolds[static_cast<std::size_t>(i)].state;
                  });
  }
  result.bodies.resize(bodies.size());
  std::size_t in_place = 0;
  for (const IslandBody& b : g.bodies) in_place += b.original != nullptr;
  run_in_chunks(tools.pool, static_cast<int>(bodies.size()), kParallelMinBodies, kBodiesPerTask,
                [&](int begin, int end) {
                  for (int i = begin; i < end; ++i)
                    result.bodies[static_cast<std::size_t>(i)] =
                        body_result(g.ids[static_cast<std::size_t>(i)],
                                    *static_cast<const btRigidBody*>(bodies[static_cast<std::size_t>(i)]));
                });
  ++counters.islands_solved;
  counters.merged_island_bodies += bodies.size();
  counters.merged_island_bodies_in_place += in_place;
  return result;
}

void BorderIslandSolver::apply(const IslandResult& result, std::map<PairKey, ManifoldState>& kept,
                               TerritoryCounters& counters) {
  // Solved in place here (solve): this world's bodies and held manifolds
  // are the result already.
  auto solved_here = std::find(solved_in_place_.begin(), solved_in_place_.end(), result.island);
  const bool in_place = solved_here != solved_in_place_.end();
  if (in_place) solved_in_place_.erase(solved_here);
  for (const BodyResult& r : result.bodies) {
    if (in_place) break;  // the bodies (every owned one of the island) are the result already
    btRigidBody* body = host_.owned_body(r.id);
    if (!body) continue;
    btRigidBody& rb = *body;
    rb.setLinearVelocity(btVector3(r.linear_velocity[0], r.linear_velocity[1], r.linear_velocity[2]));
    rb.setAngularVelocity(btVector3(r.angular_velocity[0], r.angular_velocity[1], r.angular_velocity[2]));
    btTransform t;
    t.getBasis().setValue(r.basis[0], r.basis[1], r.basis[2], r.basis[3], r.basis[4], r.basis[5], r.basis[6],
                          r.basis[7], r.basis[8]);
    t.setOrigin(btVector3(r.origin[0], r.origin[1], r.origin[2]));
    rb.setWorldTransform(t);
    rb.forceActivationState(r.activation_state);
    rb.setDeactivationTime(r.deactivation_time);
  }
  if (!in_place)
    for (JointId j : result.broken_joints) host_.break_joint(j);
  // Both sorted by key: each search starts where the last one ended.
  auto held = held_by_key_.begin();
  PairKey last{0, 0};
  for (const ManifoldState& m : result.manifolds) {
    const PairKey key{m.id0, m.id1};
    if (&m != &result.manifolds.front() && !(last < key))
      throw std::logic_error("world " + std::to_string(world_) + ": island result " + std::to_string(result.island) +
                             " has its manifolds out of order");
    last = key;
    held = std::lower_bound(held, held_by_key_.end(), key,
                            [](const std::pair<PairKey, btPersistentManifold*>& h, const PairKey& k) {
                              return h.first < k;
                            });
    if (held != held_by_key_.end() && held->first == key) {
      if (!in_place) write_manifold_points(m, *held->second);
    } else if (host_.keeps_pair(key.first, key.second) && !is_speculative(m) && !m.points.empty()) {
      // A speculative point is no contact state: it ends with the solve;
      // nor is an emptied manifold (substeps, island_substeps.h).
      kept[key] = m;
      ++counters.manifolds_returned;
    }
  }
}

}  // namespace soda
