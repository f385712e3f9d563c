// soda run --record: a run recorded through a SceneReader ends on the hash
// of the same run unrecorded (K = 1 and 4), and its file holds the run:
// every committed step, owners, sleep flags, the map, busy times, the hash.
#include <gtest/gtest.h>

#include <set>

#include "replay_test_util.h"
#include "soda/grid/partition.h"
#include "soda/replay/replay_reader.h"
#include "soda/runtime/run.h"
#include "soda/scene/registry.h"

namespace soda {
namespace {

constexpr int kSteps = 240;  // long enough for cubes to land and some to sleep

RunConfig config(int territories, const std::string& record) {
  RunConfig c;
  c.territories = territories;
  c.steps = kSteps;
  c.progress_seconds = 0;
  c.record_path = record;
  c.record_keyframe_every = 50;
  return c;
}

class Record : public ::testing::TestWithParam<int> {};

TEST_P(Record, DoesNotChangeTheHashAndHoldsTheRun) {
  const int k = GetParam();
  const Scene scene = make_scene("falling-cubes", {300, 4});
  replay::testing::TempPath file("record_k" + std::to_string(k));
  const RunResult plain = run_scene(scene, config(k, ""));
  const RunResult recorded = run_scene(scene, config(k, file.path));
  EXPECT_EQ(recorded.state_hash, plain.state_hash);
  EXPECT_EQ(recorded.record_frames, static_cast<std::uint64_t>(kSteps + 1));
  EXPECT_EQ(recorded.record_bytes, std::filesystem::file_size(file.path));

  replay::ReplayReader in(file.path);
  const replay::ViewHeader& h = in.header();
  EXPECT_EQ(h.scene, "falling-cubes");
  EXPECT_EQ(h.territories, k);
  EXPECT_EQ(h.bodies.size(), scene.bodies.size());
  EXPECT_EQ(h.dynamic_count(), scene.dynamic_count());
  EXPECT_EQ(in.step_range(), std::make_pair(std::int64_t{0}, std::int64_t{kSteps}));
  ASSERT_EQ(in.frame_count(), static_cast<std::size_t>(kSteps + 1));

  // The map: the partition the run used, on the first frame.
  const TerritoryMap map = make_partition("kmeans", scene, k, {});
  const replay::ViewFrame first = *in.frame_at(0);
  ASSERT_EQ(first.cell_owner.size(), map.owners().size());
  for (std::size_t c = 0; c < first.cell_owner.size(); ++c) ASSERT_EQ(first.cell_owner[c], map.owners()[c]);
  std::set<std::uint16_t> owners(first.owner.begin(), first.owner.end());
  EXPECT_EQ(owners.size(), static_cast<std::size_t>(k));  // every world owns bodies
  EXPECT_TRUE(first.world_busy_ms.size() == static_cast<std::size_t>(k));
  // Initial poses: the header's, within the stated error.
  std::size_t i = 0;
  for (const replay::ViewBody& b : h.bodies) {
    if (b.is_static) continue;
    for (int a = 0; a < 3; ++a)
      ASSERT_NEAR(first.position[3 * i + a], b.position[a], in.position_error_bound() + 1e-6) << "body " << b.id;
    ++i;
  }

  // The last frame: the run's hash, its sleepers; busy time measured.
  const replay::ViewFrame last = *in.frame_at(kSteps);
  ASSERT_TRUE(last.state_hash);
  EXPECT_EQ(*last.state_hash, plain.state_hash);
  std::size_t asleep = 0;
  for (std::uint8_t s : last.sleeping) asleep += s;
  EXPECT_EQ(asleep, plain.sleeping_bodies);
  EXPECT_GT(asleep, 0u);
  double busy = 0;
  for (std::size_t t = 1; t < in.frame_count(); ++t) {
    const replay::ViewFrame f = *in.frame_at(in.step_of(t));
    for (float ms : f.world_busy_ms) {
      EXPECT_GE(ms, 0.f);
      busy += ms;
    }
  }
  EXPECT_GT(busy, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Territories, Record, ::testing::Values(1, 4));

TEST(RecordRefuses, WhatASimulationDoesNotRun) {
  const Scene scene = make_scene("falling-cubes", {20, 1});
  RunConfig c = config(2, "/tmp/soda-never-written.replay");
  c.balance.policy = "diffusive";
  EXPECT_THROW(run_scene(scene, c), std::invalid_argument);
  c = config(1, "/tmp/soda-never-written.replay");
  c.world = WorldKind::Stock;
  EXPECT_THROW(run_scene(scene, c), std::invalid_argument);
  c = config(1, "/tmp/soda-never-written.replay");
  c.inputs = std::vector<UserInput>{};
  EXPECT_THROW(run_scene(scene, c), std::invalid_argument);
  EXPECT_FALSE(std::filesystem::exists("/tmp/soda-never-written.replay"));
}

TEST(RecordRefuses, AnUnwritablePathNamingIt) {
  const Scene scene = make_scene("falling-cubes", {20, 1});
  try {
    run_scene(scene, config(1, "/nonexistent-dir/r.replay"));
    FAIL() << "ran";
  } catch (const replay::ReplayError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/r.replay"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace soda
