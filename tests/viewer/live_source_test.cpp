// The live source over a running Simulation (docs/viewer.md): its pump
// thread reads while the worlds run, and the run's hash is unchanged.
#include <gtest/gtest.h>

#include <algorithm>

#include "soda/grid/partition.h"
#include "soda/runtime/simulation.h"
#include "soda/scene/registry.h"
#include "soda/viewer/live_frame_source.h"

namespace soda {
namespace {

Scene small_scene(int n) {
  SceneParams p;
  p.n = n;
  return make_scene("falling-cubes", p);
}

// The live source reads while the worlds run and ends on the run's hash,
// which it leaves unchanged (the same as a run nobody watches).
TEST(LiveFrameSource, FollowsTheRunAndEndsOnItsHash) {
  const Scene scene = small_scene(120);
  constexpr int kSteps = 90;
  std::uint64_t unwatched = 0;
  {
    Simulation sim(scene, {.territories = 1});
    sim.advance_to(sim.time_of(kSteps));
    unwatched = sim.state_hash();
  }
  SimulationConfig config;
  config.territories = 3;
  config.buffer_capacity = 4;  // small: the pump, not the buffers, must keep the worlds going
  const TerritoryMap map = make_partition(config.partition, scene, 3, config.grid);
  Simulation sim(scene, map, config);
  auto source = std::make_shared<viewer::LiveFrameSource>(sim, scene, map);
  auto first = source->newest_after(-1);  // step 0, before any world runs
  ASSERT_TRUE(first);
  EXPECT_EQ(first->step, 0);
  EXPECT_FALSE(source->finished());
  source->start();
  sim.advance_to(sim.time_of(kSteps));
  source->finish(kSteps, sim.state_hash());
  EXPECT_EQ(sim.state_hash(), unwatched);
  EXPECT_TRUE(source->finished());
  EXPECT_TRUE(source->pump_error().empty()) << source->pump_error();
  auto last = source->newest_after(-1);
  ASSERT_TRUE(last);
  EXPECT_EQ(last->step, kSteps);
  ASSERT_TRUE(last->state_hash);
  EXPECT_EQ(*last->state_hash, unwatched);
  EXPECT_EQ(last->owner.size(), scene.dynamic_count());
  EXPECT_EQ(last->cell_owner.size(), static_cast<std::size_t>(map.box().count()));
  for (std::uint16_t o : last->owner) EXPECT_LT(o, 3);
  EXPECT_EQ(source->step_range(), (std::pair<std::int64_t, std::int64_t>{kSteps, kSteps}));
}

// Inputs add and remove bodies while the source follows the run: its frames
// hold the bodies alive at their step, the added body is described
// (body()), and the run ends on the hash of the same run unwatched.
TEST(LiveFrameSource, FollowsBodiesThatComeAndGo) {
  const Scene scene = small_scene(60);
  constexpr int kSteps = 60;
  Body plank;
  plank.id = 5000;
  plank.shape = Shape::box(Vec3(1.0, 0.1, 0.3));
  plank.position = Vec3(0, 10, 0);
  auto give = [&](Simulation& sim) {
    sim.add_body(sim.time_of(20), plank);
    sim.remove_body(sim.time_of(30), 4);
  };
  std::uint64_t unwatched = 0;
  {
    Simulation sim(scene, {.territories = 1});
    give(sim);
    sim.advance_to(sim.time_of(kSteps));
    unwatched = sim.state_hash();
  }
  SimulationConfig config;
  config.territories = 2;
  const TerritoryMap map = make_partition(config.partition, scene, 2, config.grid);
  Simulation sim(scene, map, config);
  auto source = std::make_shared<viewer::LiveFrameSource>(sim, scene, map);
  source->describe(plank);
  give(sim);
  EXPECT_FALSE(source->newest_after(-1)->ids);  // step 0: the header's bodies
  source->start();
  sim.advance_to(sim.time_of(kSteps));
  source->finish(kSteps, sim.state_hash());
  EXPECT_EQ(sim.state_hash(), unwatched);
  EXPECT_TRUE(source->pump_error().empty()) << source->pump_error();
  const replay::ViewFrame last = *source->newest_after(-1);
  EXPECT_EQ(last.step, kSteps);
  ASSERT_TRUE(last.ids);
  EXPECT_TRUE(std::binary_search(last.ids->begin(), last.ids->end(), BodyId{5000}));
  EXPECT_FALSE(std::binary_search(last.ids->begin(), last.ids->end(), BodyId{4}));
  EXPECT_EQ(last.ids->size(), scene.dynamic_count());  // one in, one out
  EXPECT_EQ(last.sleeping.size(), last.ids->size());
  ASSERT_TRUE(source->body(5000));
  EXPECT_EQ(source->body(5000)->shape.kind, ShapeKind::Box);
  EXPECT_FALSE(source->body(6000));
}

}  // namespace
}  // namespace soda
