// The canonical world's contract: order independence, far-away independence,
// islands and sleeping from contacts, and a hash that sees one ulp.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>

#include "soda/worlds/canonical_world.h"
#include "soda/worlds/stock_world.h"
#include "worlds/world_test_util.h"

namespace soda {
namespace {

using test::kSteps;

struct OrderedRun {
  std::uint64_t hash;
  std::uint64_t hash_with_contacts;
  std::size_t sleeping;
};

OrderedRun run_canonical(const Scene& s, const std::vector<std::size_t>& order, int steps) {
  CanonicalWorld w(s, order);
  test::run(w, steps);
  return {w.state_hash(), w.state_hash(true), w.sleeping_count()};
}

void expect_order_independent(const std::string& name) {
  const Scene s = test::scene(name);
  const std::size_t n = s.bodies.size();
  const OrderedRun a = run_canonical(s, test::identity_order(n), kSteps);
  const OrderedRun b = run_canonical(s, test::reversed_order(n), kSteps);
  const OrderedRun c = run_canonical(s, test::shuffled_order(n, 7), kSteps);
  std::printf("[ %s %s ] canonical, %d steps: scene order %s, reversed %s, shuffled %s (sleeping %zu %zu %zu)\n",
              name.c_str(), kPrecisionName, kSteps, hash_hex(a.hash).c_str(), hash_hex(b.hash).c_str(),
              hash_hex(c.hash).c_str(), a.sleeping, b.sleeping, c.sleeping);
  EXPECT_EQ(hash_hex(a.hash), hash_hex(b.hash));
  EXPECT_EQ(hash_hex(a.hash), hash_hex(c.hash));
  EXPECT_EQ(hash_hex(a.hash_with_contacts), hash_hex(b.hash_with_contacts));
  EXPECT_EQ(hash_hex(a.hash_with_contacts), hash_hex(c.hash_with_contacts));
  EXPECT_EQ(a.sleeping, b.sleeping);
  EXPECT_EQ(a.sleeping, c.sleeping);
}

TEST(CanonicalWorld, ShuffledInsertionFallingCubes) { expect_order_independent("falling-cubes"); }
TEST(CanonicalWorld, ShuffledInsertionCubePile) { expect_order_independent("cube-pile"); }

// Makes the canonical test meaningful: stock Bullet gives another result for
// another insertion order.
TEST(StockWorld, IsNotOrderIndependent) {
  const Scene s = test::scene("cube-pile");
  StockWorld a(s, test::identity_order(s.bodies.size()));
  StockWorld b(s, test::shuffled_order(s.bodies.size(), 7));
  test::run(a, 300);
  test::run(b, 300);
  std::printf("[ cube-pile %s ] stock, 300 steps: scene order %s, shuffled %s\n", kPrecisionName,
              hash_hex(a.state_hash()).c_str(), hash_hex(b.state_hash()).c_str());
  EXPECT_NE(a.state_hash(), b.state_hash());
}

// Group A alone, and A with group B far away (ids interleaved with A's, so
// B's bodies sit between A's in every id-ordered loop): A's bodies end in the
// same states.
TEST(CanonicalWorld, InsertionOrderMustBeAPermutation) {
  const Scene s = test::scene("cube-pile", 20);
  std::vector<std::size_t> order = test::identity_order(s.bodies.size());
  order[3] = order[4];  // body 4 twice, body 3 never
  EXPECT_THROW(CanonicalWorld(s, order), std::invalid_argument);
  order = test::identity_order(s.bodies.size());
  order.back() = s.bodies.size();  // out of range
  EXPECT_THROW(CanonicalWorld(s, order), std::invalid_argument);
  order.pop_back();  // too short
  EXPECT_THROW(CanonicalWorld(s, order), std::invalid_argument);
  EXPECT_NO_THROW(CanonicalWorld(s, test::reversed_order(s.bodies.size())));
}

TEST(CanonicalWorld, FarAwayGroupChangesNothing) {
  Scene a = test::scene("cube-pile", 200, 3);
  Scene b = test::scene("falling-cubes", 200, 5);
  for (Body& body : a.bodies) body.id = 2 * body.id;
  Scene both = a;
  for (Body body : b.bodies) {
    body.id = 2 * body.id + 1;
    body.position.x() += 500.0;
    both.bodies.push_back(body);
  }
  CanonicalWorld alone(a, test::shuffled_order(a.bodies.size(), 1));
  CanonicalWorld together(both, test::shuffled_order(both.bodies.size(), 2));
  test::run(alone, kSteps);
  test::run(together, kSteps);
  std::vector<BodyState> mine;
  for (const BodyState& st : together.body_states())
    if (st.id % 2 == 0) mine.push_back(st);
  const std::uint64_t ha = state_hash(alone.body_states()), hb = state_hash(mine);
  std::printf("[ far-away %s ] group A alone %s, A with B %s; sleeping %zu / %zu\n", kPrecisionName,
              hash_hex(ha).c_str(), hash_hex(hb).c_str(), alone.sleeping_count(), together.sleeping_count());
  ASSERT_EQ(mine.size(), alone.body_states().size());
  EXPECT_EQ(hash_hex(ha), hash_hex(hb));
}

// Deactivation is physics: bodies do go to sleep, islands are counted.
TEST(CanonicalWorld, BodiesFallAsleep) {
  const Scene s = test::scene("falling-cubes");
  CanonicalWorld w(s);
  std::size_t max_sleeping_islands = 0;
  for (int i = 0; i < kSteps; ++i) {
    w.step();
    max_sleeping_islands = std::max(max_sleeping_islands, w.last_step_stats().sleeping_islands);
  }
  const StepStats& st = w.last_step_stats();
  std::printf("[ falling-cubes %s ] after %d steps: %zu of %zu dynamic bodies asleep; islands %zu "
              "(awake %zu, sleeping %zu, lone %zu), manifolds %zu (solved %zu), pairs %zu\n",
              kPrecisionName, kSteps, w.sleeping_count(), s.dynamic_count(), st.islands, st.awake_islands,
              st.sleeping_islands, st.lone_bodies, st.contact_manifolds, st.solved_manifolds,
              st.broadphase_pairs);
  EXPECT_GT(w.sleeping_count(), s.dynamic_count() / 2);
  EXPECT_GT(max_sleeping_islands, 0u);
  EXPECT_EQ(st.islands, st.awake_islands + st.sleeping_islands);
}

TEST(StateHash, OneUlpOfOneBodyChangesIt) {
  const Scene s = test::scene("falling-cubes", 50);
  CanonicalWorld w(s);
  test::run(w, 30);
  const std::vector<BodyState> base = w.body_states();
  const std::uint64_t h = state_hash(base);
  int changed = 0;
  for (int field = 0; field < 4; ++field) {
    std::vector<BodyState> v = base;
    btScalar* x = field == 0   ? &v[17].origin[0]
                  : field == 1 ? &v[17].basis[4]
                  : field == 2 ? &v[17].linear_velocity[1]
                               : &v[17].angular_velocity[2];
    *x = std::nextafter(*x, btScalar(1e30));
    const std::uint64_t h2 = state_hash(v);
    std::printf("[ one ulp %s ] field %d: %s -> %s\n", kPrecisionName, field, hash_hex(h).c_str(),
                hash_hex(h2).c_str());
    changed += h2 != h;
  }
  EXPECT_EQ(changed, 4);
  std::vector<BodyState> v = base;
  v[17].activation_state = v[17].activation_state == 1 ? 2 : 1;
  EXPECT_NE(state_hash(v), h);
  // Order of the input does not matter, ids do.
  std::vector<BodyState> rev(base.rbegin(), base.rend());
  EXPECT_EQ(state_hash(rev), h);
}

}  // namespace
}  // namespace soda
