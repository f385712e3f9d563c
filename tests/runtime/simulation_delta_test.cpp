// Delta entries under a Simulation (SimulationConfig::delta_entries,
// docs/transform-buffer.md): the frames a reader gets are the same, bit for
// bit, with delta entries on and off, on one territory and on four with
// speculation (rollbacks republish entries), and equal the one-world
// reference; with most bodies asleep a buffered step stores a fraction of
// them. Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <cstdio>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

struct Frames {
  std::vector<std::vector<ScenePose>> frames;
  std::size_t delta_bytes_per_entry = 0;
  std::size_t total_bytes_per_entry = 0;  // keys included
};

// Reads every step's frame while the worlds run (one reader, one step at a
// time), and the buffers' memory after the last step.
Frames read_all(const Scene& s, int steps, int territories, int anticipation, bool delta) {
  SimulationConfig config{.territories = territories, .buffer_capacity = 16};
  config.runtime.anticipation = anticipation;
  config.runtime.checkpoint_every = 1;
  config.runtime.eager_bets = anticipation > 0;
  config.delta_entries = delta;
  Simulation sim(s, config);
  SceneReader reader = sim.add_reader();
  Frames out;
  for (int k = 0; k <= steps; ++k) {
    EXPECT_TRUE(sim.advance_to(sim.time_of(k)));
    std::optional<SceneFrame> f = reader.read_at(sim.time_of(k));
    EXPECT_TRUE(f && f->step == k);
    out.frames.push_back(f ? f->poses : std::vector<ScenePose>{});
  }
  std::size_t bytes = 0, total = 0, entries = 0;
  for (const BufferMemory& m : sim.buffer_memory()) bytes += m.delta_bytes, total += m.total(), entries += m.entries;
  out.delta_bytes_per_entry = entries ? bytes / entries : 0;
  out.total_bytes_per_entry = entries ? total / entries : 0;
  return out;
}

TEST(SimulationDelta, FramesEqualWithDeltaOnAndOff) {
  constexpr int kSteps = 60;
  const Scene s = test::scene("sleepers", 600);  // 600 asleep, 6 falling onto them
  const test::Reference ref = test::reference_run(s, kSteps);
  struct Case {
    int territories, anticipation;
    bool delta;
  };
  const Case cases[] = {{1, 0, false}, {1, 0, true}, {4, 8, true}, {4, 8, false}};
  std::size_t bytes_on = 0, total_on = 0, total_off = 0;
  for (const Case& c : cases) {
    const Frames got = read_all(s, kSteps, c.territories, c.anticipation, c.delta);
    for (int k = 0; k <= kSteps; ++k)
      ASSERT_EQ(test::frame_difference(got.frames[static_cast<std::size_t>(k)], ref.frames[static_cast<std::size_t>(k)]),
                "")
          << "K " << c.territories << ", anticipation " << c.anticipation << ", delta " << c.delta << ", step " << k;
    if (c.territories == 1 && c.delta) bytes_on = got.delta_bytes_per_entry, total_on = got.total_bytes_per_entry;
    if (c.territories == 1 && !c.delta) total_off = got.total_bytes_per_entry;
  }
  std::printf("[ sleepers 600, K 1 ] bytes per held entry: delta on %zu (%zu with the key's share), off %zu\n",
              bytes_on, total_on, total_off);
  EXPECT_LT(bytes_on * 4, 600 * sizeof(ScenePose));  // far below one pose per body
}

}  // namespace
}  // namespace soda
