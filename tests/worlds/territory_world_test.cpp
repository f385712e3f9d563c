// The territory world alone: with one territory (no neighbours, no ghosts)
// its staged step is the canonical world's step; bodies outside the
// partitioned exactness contract are refused.
#include <gtest/gtest.h>

#include <cstdio>

#include "soda/worlds/canonical_world.h"
#include "soda/worlds/territory_world.h"
#include "worlds/world_test_util.h"

namespace soda {
namespace {

void step_alone(TerritoryWorld& w) {
  w.predict();
  w.apply_ghosts({});
  w.collide();
  w.build_islands();
  EXPECT_TRUE(w.border_fragments({}).empty());
  w.finish_islands();
  w.integrate();
  for (const auto& [n, batch] : w.migrate()) EXPECT_TRUE(batch.migrants.empty());
  w.absorb_migrants({});
}

std::uint64_t hash_of(const TerritoryWorld& w) {
  std::vector<BodyState> states = w.owned_states();
  for (const BodyState& s : w.static_states()) states.push_back(s);
  return state_hash(states);
}

TEST(TerritoryWorld, OneTerritoryStepsAsTheCanonicalWorld) {
  for (const char* name : {"cube-pile", "falling-cubes", "projectile"}) {
    const Scene s = test::scene(name, 200);
    CanonicalWorld reference(s);
    TerritoryWorld alone(s, 0, TerritoryMap());
    for (int i = 0; i < 300; ++i) {
      reference.step();
      step_alone(alone);
    }
    std::printf("[ %s %s ] canonical %s, one territory world %s, %zu asleep\n", name, kPrecisionName,
                hash_hex(reference.state_hash()).c_str(), hash_hex(hash_of(alone)).c_str(), alone.sleeping_count());
    EXPECT_EQ(hash_hex(hash_of(alone)), hash_hex(reference.state_hash()));
    EXPECT_EQ(alone.steps_done(), 300);
    EXPECT_EQ(alone.owned_count() + alone.static_count(), s.bodies.size());
    EXPECT_EQ(alone.ghost_count(), 0u);
    EXPECT_EQ(alone.sleeping_count(), reference.sleeping_count());
  }
}

TEST(TerritoryWorld, RefusesBodiesOutsideTheExactnessContract) {
  Scene s = test::scene("falling-cubes", 3);
  s.bodies.back().shape = Shape::box(Vec3(2.0, 2.0, 2.0));  // 4 m cube: its breaking threshold is too large
  try {
    TerritoryWorld w(s, 0, TerritoryMap());
    ADD_FAILURE() << "no exception";
  } catch (const PartitionError& e) {
    std::printf("[ contract ] %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find("body 3"), std::string::npos);
  }
}

}  // namespace
}  // namespace soda
