// BorderIslandSolver (worlds/src/border_island_solver.h) on its own, with a
// host made of plain Bullet bodies: a pile's state (bodies and contacts,
// from a canonical world) cut into two fragments of two worlds.
//  - the result is a pure function of the fragments: any order, any world
//    that solves it on copies, the same bits (invariant 1);
//  - a world solving its own fragment in place gets those bits too, leaves
//    them in its own bodies and points its held manifolds back at their own
//    bodies (invariant 2);
//  - a fragment that is not the one noted, a body with two owners, a pair
//    with two holders, a pair held twice: errors (invariants 3, 4);
//  - apply() writes owned bodies and returns the contact state of pairs this
//    world keeps but did not hold.
#include <algorithm>
#include <cstring>
#include <map>
#include <memory>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

#include "body_factory.h"
#include "border_island_solver.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/canonical_world.h"
#include "soda/worlds/territory_world.h"
#include "soda/worlds/value_codec.h"
#include "world_test_util.h"

namespace soda {
namespace {

// Bullet bodies made from snapshots, by id, with their shapes.
struct Bodies {
  std::vector<std::shared_ptr<btCollisionShape>> shapes;
  std::map<BodyId, std::unique_ptr<btRigidBody>> by_id;
  btRigidBody* add(const BodySnapshot& b) {
    shapes.push_back(make_collision_shape(b.description.shape));
    auto body = make_body_from_state(b.description, *shapes.back(), b.state);
    if (!b.description.is_static) write_dynamic_state(*body, b.state);  // activation state and timer too
    btRigidBody* raw = body.get();
    by_id[b.description.id] = std::move(body);
    return raw;
  }
  btRigidBody* find(BodyId id) const {
    auto it = by_id.find(id);
    return it == by_id.end() ? nullptr : it->second.get();
  }
};

// A world with statics, owned bodies and one component (its own fragment).
struct Host final : BorderIslandHost {
  Bodies statics, owned, ghosts;
  std::vector<btCollisionObject*> component;       // owned and ghosts, ascending id
  std::vector<btPersistentManifold*> manifolds;    // held, by key
  std::vector<std::unique_ptr<btPersistentManifold>> manifold_storage;
  std::vector<std::pair<BodyId, BodyId>> kept_pairs;
  btCollisionObject* const* component_bodies(int, int& count) const override {
    count = static_cast<int>(component.size());
    return component.data();
  }
  btPersistentManifold* const* component_manifolds(int, int& count) const override {
    count = static_cast<int>(manifolds.size());
    return manifolds.data();
  }
  bool owns_body(const btCollisionObject* body) const override {
    return owned.find(static_cast<BodyId>(body->getUserIndex())) == body;
  }
  btCollisionObject* static_body(BodyId id) const override { return statics.find(id); }
  btRigidBody* owned_body(BodyId id) const override { return owned.find(id); }
  bool keeps_pair(BodyId id0, BodyId id1) const override {
    for (const auto& p : kept_pairs)
      if (p == std::make_pair(id0, id1)) return true;
    return false;
  }
  btTypedConstraint* held_joint(JointId) const override { return nullptr; }  // no joints here
  void break_joint(JointId) override {}
};

struct Pile {
  WorldSnapshot state;            // after some steps
  Fragment a, b;                  // worlds 0 and 1: every dynamic body and contact, alternately
};

Pile make_pile() {
  Pile p;
  CanonicalWorld world(test::scene("cube-pile", 40));
  test::run(world, 80);
  p.state = world.snapshot();
  p.a.world = 0, p.b.world = 1;
  bool to_a = true;
  for (const BodySnapshot& s : p.state.bodies) {
    if (s.description.is_static) continue;
    BodyRecord r;
    r.body = s;
    r.total_force[1] = btScalar(-9.81 * s.description.mass);
    (to_a ? p.a : p.b).bodies.push_back(r);
    to_a = !to_a;
  }
  to_a = true;
  for (const ManifoldState& m : p.state.manifolds) {
    (to_a ? p.a : p.b).manifolds.push_back(m);
    to_a = !to_a;
  }
  p.a.root = p.a.bodies.front().body.description.id;
  p.b.root = p.b.bodies.front().body.description.id;
  return p;
}

void add_statics(Host& h, const WorldSnapshot& s) {
  for (const BodySnapshot& b : s.bodies)
    if (b.description.is_static) h.statics.add(b);
}

// The bits of three components of a vector.
bool same3(const btScalar* a, const btVector3& v) {
  const btScalar b[3] = {v[0], v[1], v[2]};
  return std::memcmp(a, b, sizeof b) == 0;
}

bool same(const IslandResult& x, const IslandResult& y) {
  if (x.island != y.island || x.bodies.size() != y.bodies.size() || x.manifolds.size() != y.manifolds.size())
    return false;
  for (std::size_t i = 0; i < x.bodies.size(); ++i) {
    const BodyResult &p = x.bodies[i], &q = y.bodies[i];
    if (p.id != q.id || std::memcmp(p.linear_velocity, q.linear_velocity, sizeof p.linear_velocity) ||
        std::memcmp(p.angular_velocity, q.angular_velocity, sizeof p.angular_velocity) ||
        std::memcmp(p.basis, q.basis, sizeof p.basis) || std::memcmp(p.origin, q.origin, sizeof p.origin) ||
        p.activation_state != q.activation_state ||
        std::memcmp(&p.deactivation_time, &q.deactivation_time, sizeof p.deactivation_time))
      return false;
  }
  for (std::size_t i = 0; i < x.manifolds.size(); ++i)
    if (!same_bits(x.manifolds[i], y.manifolds[i])) return false;
  return true;
}

IslandResult solve_on_copies(const Pile& p, WorldId world, const std::vector<const Fragment*>& island) {
  Host host;
  add_statics(host, p.state);
  BorderIslandSolver solver(world, host);
  ColouredSolver coloured;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btContactSolverInfo info, scratch;
  TerritoryCounters counters;
  solver.begin_fragments();
  solver.end_fragments();
  IslandResult r = solver.solve(island, {coloured, dispatcher, info, scratch, nullptr}, 7, counters);
  EXPECT_EQ(counters.islands_solved, 1u);
  EXPECT_EQ(counters.merged_island_bodies, p.a.bodies.size() + p.b.bodies.size());
  EXPECT_EQ(counters.merged_island_bodies_in_place, 0u);
  return r;
}

TEST(BorderIslandSolver, APureFunctionOfItsFragments) {
  const Pile p = make_pile();
  ASSERT_GT(p.state.manifolds.size(), 10u);
  const IslandResult one = solve_on_copies(p, 5, {&p.a, &p.b});
  const IslandResult other = solve_on_copies(p, 6, {&p.b, &p.a});
  EXPECT_TRUE(same(one, other));
  ASSERT_EQ(one.bodies.size(), p.a.bodies.size() + p.b.bodies.size());
  for (std::size_t i = 1; i < one.bodies.size(); ++i) EXPECT_LT(one.bodies[i - 1].id, one.bodies[i].id);
  // The pile moved (a solve that changed nothing would pass the above too).
  bool moved = false;
  for (const BodyResult& r : one.bodies)
    for (const BodySnapshot& s : p.state.bodies)
      if (s.description.id == r.id)
        moved = moved || std::memcmp(r.linear_velocity, s.state.linear_velocity, sizeof r.linear_velocity) != 0;
  EXPECT_TRUE(moved);
}

TEST(BorderIslandSolver, OwnFragmentInPlaceGivesTheSameBits) {
  const Pile p = make_pile();
  const IslandResult copies = solve_on_copies(p, 5, {&p.a, &p.b});

  Host host;  // world 0: fragment a is its own; b's bodies are ghosts here
  add_statics(host, p.state);
  for (const BodyRecord& r : p.a.bodies) {
    btRigidBody* body = host.owned.add(r.body);
    body->applyCentralForce(btVector3(r.total_force[0], r.total_force[1], r.total_force[2]));
  }
  for (const BodyRecord& r : p.b.bodies) host.ghosts.add(r.body);
  for (const auto* set : {&host.owned, &host.ghosts})
    for (const auto& [id, body] : set->by_id) host.component.push_back(body.get());
  std::sort(host.component.begin(), host.component.end(),
            [](const btCollisionObject* x, const btCollisionObject* y) { return x->getUserIndex() < y->getUserIndex(); });
  auto any = [&](BodyId id) -> btCollisionObject* {
    for (const auto* set : {&host.owned, &host.ghosts, &host.statics})
      if (btRigidBody* b = set->find(id)) return b;
    return nullptr;
  };
  std::vector<std::pair<const btCollisionObject*, const btCollisionObject*>> ends;
  for (const ManifoldState& m : p.a.manifolds) {
    // Thresholds as Bullet's dispatcher gives a manifold (the solver reads
    // the processing threshold), as the solver's copies have them.
    btCollisionObject* b0 = any(m.id0);
    btCollisionObject* b1 = any(m.id1);
    const btScalar breaking = btMin(b0->getCollisionShape()->getContactBreakingThreshold(gContactBreakingThreshold),
                                    b1->getCollisionShape()->getContactBreakingThreshold(gContactBreakingThreshold));
    const btScalar processing = btMin(b0->getContactProcessingThreshold(), b1->getContactProcessingThreshold());
    host.manifold_storage.push_back(std::make_unique<btPersistentManifold>(b0, b1, 0, breaking, processing));
    write_manifold_points(m, *host.manifold_storage.back());
    host.manifolds.push_back(host.manifold_storage.back().get());
    ends.emplace_back(any(m.id0), any(m.id1));
  }
  BorderIslandSolver solver(0, host);
  ColouredSolver coloured;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btContactSolverInfo info, scratch;
  TerritoryCounters counters;
  solver.begin_fragments();
  for (std::size_t i = 0; i < p.a.manifolds.size(); ++i)
    solver.hold({p.a.manifolds[i].id0, p.a.manifolds[i].id1}, host.manifolds[i]);
  solver.note_own_fragment(p.a.root, 0);
  solver.end_fragments();
  const IslandResult in_place = solver.solve({&p.b, &p.a}, {coloured, dispatcher, info, scratch, nullptr}, 7, counters);
  EXPECT_TRUE(same(copies, in_place));
  EXPECT_EQ(counters.merged_island_bodies_in_place, p.a.bodies.size());
  // The own bodies hold the result; the held manifolds their own ends.
  for (const BodyResult& r : in_place.bodies) {
    if (btRigidBody* b = host.owned.find(r.id)) EXPECT_TRUE(same3(r.linear_velocity, b->getLinearVelocity())) << r.id;
  }
  for (std::size_t i = 0; i < host.manifolds.size(); ++i) {
    EXPECT_EQ(host.manifolds[i]->getBody0(), ends[i].first);
    EXPECT_EQ(host.manifolds[i]->getBody1(), ends[i].second);
  }
  // Taken once: the same fragment again is solved on copies.
  std::map<std::pair<BodyId, BodyId>, ManifoldState> kept;
  solver.apply(in_place, kept, counters);  // in place: nothing to write, nothing kept
  EXPECT_TRUE(kept.empty());
}

TEST(BorderIslandSolver, RefusesBrokenFragments) {
  const Pile p = make_pile();
  Host host;
  add_statics(host, p.state);
  BorderIslandSolver solver(0, host);
  ColouredSolver coloured;
  btDefaultCollisionConfiguration config;
  btCollisionDispatcher dispatcher(&config);
  btContactSolverInfo info, scratch;
  TerritoryCounters counters;
  const BorderIslandTools tools{coloured, dispatcher, info, scratch, nullptr};
  Fragment twice = p.b;
  twice.world = 2;
  twice.manifolds.clear();
  EXPECT_THROW(solver.solve({&p.a, &p.b, &twice}, tools, 7, counters), PartitionError);  // two owners
  Fragment held_twice = p.b;
  held_twice.world = 2;
  held_twice.bodies.clear();
  EXPECT_THROW(solver.solve({&p.a, &p.b, &held_twice}, tools, 7, counters), PartitionError);  // two holders
  solver.begin_fragments();
  solver.hold({1, 2}, nullptr);
  solver.hold({1, 2}, nullptr);
  EXPECT_THROW(solver.end_fragments(), std::logic_error);
  // An own fragment that is not the one noted (its manifolds differ).
  solver.begin_fragments();
  solver.note_own_fragment(p.a.root, 0);  // host.manifolds is empty
  solver.end_fragments();
  EXPECT_THROW(solver.solve({&p.a, &p.b}, tools, 7, counters), std::logic_error);
}

TEST(BorderIslandSolver, ApplyWritesOwnedBodiesAndReturnsKeptPairs) {
  const Pile p = make_pile();
  const IslandResult result = solve_on_copies(p, 5, {&p.a, &p.b});
  Host host;  // world 1: owns b's bodies, holds nothing, keeps a's first pair
  add_statics(host, p.state);
  for (const BodyRecord& r : p.b.bodies) host.owned.add(r.body);
  const ManifoldState& returned = p.a.manifolds.front();
  host.kept_pairs.emplace_back(returned.id0, returned.id1);
  BorderIslandSolver solver(1, host);
  solver.begin_fragments();
  solver.end_fragments();
  std::map<std::pair<BodyId, BodyId>, ManifoldState> kept;
  TerritoryCounters counters;
  solver.apply(result, kept, counters);
  for (const BodyResult& r : result.bodies) {
    btRigidBody* b = host.owned.find(r.id);
    if (!b) continue;
    EXPECT_TRUE(same3(r.linear_velocity, b->getLinearVelocity())) << r.id;
    EXPECT_TRUE(same3(r.origin, b->getWorldTransform().getOrigin())) << r.id;
  }
  bool has_points = false;
  for (const ManifoldState& m : result.manifolds)
    if (m.id0 == returned.id0 && m.id1 == returned.id1) has_points = !m.points.empty();
  EXPECT_EQ(kept.size(), has_points ? 1u : 0u);
  EXPECT_EQ(counters.manifolds_returned, kept.size());
}

}  // namespace
}  // namespace soda
