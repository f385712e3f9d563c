// soda run --record: a run recorded through a SceneReader ends on the hash
// of the same run unrecorded (K = 1 and 4), and its file holds the run:
// every committed step, owners, sleep flags, the map, busy times, the hash;
// with inputs, the bodies they add from their step on and not those they
// remove after theirs.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
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

// Inputs of a run: a plank added at step 40 (boundary 40: in frames 41 on),
// body 5 removed at step 60 (in frames up to 60), a push at step 20.
constexpr BodyId kAdded = 100000;
constexpr BodyId kRemoved = 5;
constexpr std::int64_t kAddStep = 40, kRemoveStep = 60;

std::vector<UserInput> inputs() {
  UserInput push;
  push.kind = UserInput::Kind::SetVelocity;
  push.step = 20;
  push.id = 7;
  push.linear = Vec3(2, 3, 0);
  UserInput add;
  add.kind = UserInput::Kind::AddBody;
  add.step = kAddStep;
  add.sequence = 1;
  add.body.id = kAdded;
  add.body.shape = Shape::box(Vec3(1.0, 0.1, 0.25));
  add.body.mass = 2.0;
  add.body.position = Vec3(0, 14, 0);
  add.body.linear_velocity = Vec3(0, -3, 0);
  UserInput remove;
  remove.kind = UserInput::Kind::RemoveBody;
  remove.step = kRemoveStep;
  remove.sequence = 2;
  remove.id = kRemoved;
  return {push, add, remove};
}

bool holds(const replay::ViewFrame& f, const replay::ViewHeader& h, BodyId id) {
  if (!f.ids) {
    const std::optional<replay::ViewBody> b = replay::FrameSource::header_body(h, id);
    return b && !b->is_static;
  }
  return std::binary_search(f.ids->begin(), f.ids->end(), id);
}

class RecordInputs : public ::testing::TestWithParam<int> {};

TEST_P(RecordInputs, BodiesComeAndGoAndTheHashIsTheUnrecordedRuns) {
  const int k = GetParam();
  const Scene scene = make_scene("falling-cubes", {300, 4});
  replay::testing::TempPath file("record_inputs_k" + std::to_string(k));
  RunConfig plain_config = config(k, "");
  plain_config.steps = 120;
  plain_config.inputs = inputs();
  plain_config.inputs_source = "record_test inputs";
  RunConfig record_config = plain_config;
  record_config.record_path = file.path;
  const RunResult plain = run_scene(scene, plain_config);
  const RunResult recorded = run_scene(scene, record_config);
  EXPECT_EQ(recorded.state_hash, plain.state_hash);
  std::printf("K = %d: state_hash %016llx recorded and unrecorded\n", k,
              static_cast<unsigned long long>(plain.state_hash));

  replay::ReplayReader in(file.path);
  EXPECT_EQ(in.version(), 3u);
  ASSERT_EQ(in.frame_count(), 121u);
  ASSERT_EQ(in.added_bodies().size(), 1u);
  EXPECT_EQ(in.added_bodies()[0].id, kAdded);
  EXPECT_EQ(in.added_bodies()[0].shape.kind, ShapeKind::Box);
  EXPECT_EQ(in.added_bodies()[0].shape.half_extents, Vec3(1.0, 0.1, 0.25));
  const replay::ViewHeader& h = in.header();
  EXPECT_EQ(h.dynamic_count(), 300u);  // the bodies at the start
  // Every frame, read backwards (each from its keyframe): the added body
  // from its step on, the removed one up to its step.
  for (std::int64_t s = 120; s >= 0; --s) {
    const replay::ViewFrame f = *in.frame_at(s);
    EXPECT_EQ(holds(f, h, kAdded), s > kAddStep) << "step " << s;
    EXPECT_EQ(holds(f, h, kRemoved), s <= kRemoveStep) << "step " << s;
    EXPECT_EQ(f.ids.has_value(), s > kAddStep) << "step " << s;
    const std::size_t n = 300 + (s > kAddStep ? 1 : 0) - (s > kRemoveStep ? 1 : 0);
    EXPECT_EQ(f.sleeping.size(), n) << "step " << s;
    EXPECT_EQ(f.position.size(), 3 * n) << "step " << s;
  }
  // The plank where the input put it, within the file's error, on the
  // first frame that holds it (one step of falling later).
  const replay::ViewFrame first = *in.frame_at(kAddStep + 1);
  const std::size_t at = static_cast<std::size_t>(
      std::lower_bound(first.ids->begin(), first.ids->end(), kAdded) - first.ids->begin());
  EXPECT_NEAR(first.position[3 * at + 1], 14.0 - 3.0 / 60.0, 0.01);
  const replay::ViewFrame last = *in.frame_at(120);
  ASSERT_TRUE(last.state_hash);
  EXPECT_EQ(*last.state_hash, plain.state_hash);
}

INSTANTIATE_TEST_SUITE_P(Territories, RecordInputs, ::testing::Values(1, 4));

TEST(RecordRefuses, WhatASimulationDoesNotRun) {
  const Scene scene = make_scene("falling-cubes", {20, 1});
  RunConfig c = config(2, "/tmp/soda-never-written.replay");
  c.runtime.balance.policy = "diffusive";
  EXPECT_THROW(run_scene(scene, c), std::invalid_argument);
  c = config(1, "/tmp/soda-never-written.replay");
  c.world = WorldKind::Stock;
  EXPECT_THROW(run_scene(scene, c), std::invalid_argument);
  c = config(1, "/tmp/soda-never-written.replay");
  c.sync_test = 2;
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
