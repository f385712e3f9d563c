// Messages by destination and kind (WorldMetrics::traffic,
// soda/runtime/message_traffic.h): on two territories split at x = 0 the
// counts are the step's protocol (one Ghosts and one Migrants per neighbour
// per step, Glue only after ghosts) and the bytes are the codec's sizes.
#include "runtime/partitioned_test_util.h"

#include <memory>

#include "step/message_tally.h"
#include "soda/runtime/message_codec.h"

namespace soda {
namespace {

constexpr int kSteps = 60;
constexpr std::uint64_t kN = kSteps;

std::size_t at(MessageKind kind) { return static_cast<std::size_t>(kind) - 1; }

Body sphere(BodyId id, double x, double vx) {
  Body b;
  b.id = id;
  b.shape = Shape::sphere(0.5);
  b.mass = 1.0;
  b.position = Vec3(x, 1.0, 0.0);
  b.linear_velocity = Vec3(vx, 0.0, 0.0);
  return b;
}

// No gravity, no ground: spheres at y = 1; 2 m cells from the origin, the
// cells the spheres span cut in two halves (the tests place them so that
// the border is x = 0).
Scene spheres(std::vector<Body> bodies) {
  Scene s;
  s.name = "traffic";
  s.settings.gravity = Vec3::Zero();
  s.bodies = std::move(bodies);
  return s;
}

std::unique_ptr<PartitionedWorld> run(const Scene& s, int steps) {
  auto world = std::make_unique<PartitionedWorld>(s, make_partition("grid:2x1x1", s, 2, test::border_grid()),
                                                  PartitionedOptions{});
  world->step(steps);
  return world;
}

const MessageFlow* find(const MessageTraffic& t, WorldId to, MessageKind kind) {
  for (const MessageFlow& f : t.flows)
    if (f.to == to && f.kind == kind) return &f;
  return nullptr;
}

std::size_t encoded_size(WorldId from, WorldId to, decltype(Message::payload) payload) {
  return encode_message(Message{from, to, 0, std::move(payload)}).size();
}

// Every flow's counts add up to the world's own counters.
void expect_sums(const WorldMetrics& m) {
  std::uint64_t messages = 0, bytes = 0, stage_bytes = 0;
  for (const MessageFlow& f : m.traffic.flows) {
    messages += f.messages;
    bytes += f.bytes;
    EXPECT_GT(f.bytes, 0u) << "world " << m.world;  // serialised: every message has a size
    EXPECT_LE(f.steps, static_cast<std::uint64_t>(m.steps));
    EXPECT_LE(f.steps, f.messages);
    EXPECT_LE(f.messages, f.steps * f.max_per_step);
  }
  for (const StageCost& c : m.stages) stage_bytes += c.bytes;
  EXPECT_EQ(messages, m.messages_sent) << "world " << m.world;
  EXPECT_EQ(bytes, stage_bytes) << "world " << m.world;
}

// Two spheres far from the border: each world sends the other exactly one
// empty Ghosts and one empty Migrants per step, nothing else.
TEST(MessageTraffic, QuietBorderIsOneEmptyGhostsAndMigrantsPerStep) {
  const Scene s = spheres({sphere(1, -5.0, 0.0), sphere(2, 5.0, 0.0)});
  const std::unique_ptr<PartitionedWorld> world = run(s, kSteps);
  std::uint64_t bytes = 0;
  for (const WorldMetrics& m : world->metrics()) {
    const WorldId other = 1 - m.world;
    ASSERT_EQ(m.steps, kSteps);
    ASSERT_EQ(m.traffic.flows.size(), 2u) << "world " << m.world;
    const MessageFlow* ghosts = find(m.traffic, other, MessageKind::Ghosts);
    const MessageFlow* migrants = find(m.traffic, other, MessageKind::Migrants);
    ASSERT_TRUE(ghosts && migrants);
    for (const MessageFlow* f : {ghosts, migrants}) {
      EXPECT_EQ(f->messages, kN);
      EXPECT_EQ(f->steps, kN);
      EXPECT_EQ(f->max_per_step, 1u);
    }
    EXPECT_EQ(ghosts->bytes, kN * encoded_size(m.world, other, GhostBatch{}));
    EXPECT_EQ(migrants->bytes, kN * encoded_size(m.world, other, MigrantBatch{}));
    for (std::size_t k = 0; k < kMessageKindCount; ++k) {
      const bool every_step = k == at(MessageKind::Ghosts) || k == at(MessageKind::Migrants);
      EXPECT_EQ(m.traffic.rounds[k], every_step ? kN : 0u) << "kind " << k + 1;
    }
    EXPECT_EQ(m.traffic.island_depth_sum, 0u);
    expect_sums(m);
    bytes += ghosts->bytes + migrants->bytes;
  }
  EXPECT_EQ(bytes, world->bytes_sent());
}

// A sphere flying into a resting one that touches it on the border (x = 0),
// then across it (a third, far away at x = 3, makes the cells -2..1 and the
// cut x = 0): ghosts both ways, so Glue, a border island merged over
// both worlds (a tree of depth 1) and one migration; still one Ghosts and
// one Migrants per step each way.
TEST(MessageTraffic, BorderContactAddsGlueMergeAndDepth) {
  const Scene s = spheres({sphere(1, -3.0, 4.0), sphere(2, 0.5, 0.0), sphere(3, 3.0, 0.0)});
  const std::unique_ptr<PartitionedWorld> world = run(s, kSteps);
  std::uint64_t bytes = 0, merged = 0, migrants_nonempty = 0;
  for (const WorldMetrics& m : world->metrics()) {
    const WorldId other = 1 - m.world;
    for (MessageKind kind : {MessageKind::Ghosts, MessageKind::Migrants}) {
      const MessageFlow* f = find(m.traffic, other, kind);
      ASSERT_TRUE(f);
      EXPECT_EQ(f->messages, kN);
      EXPECT_EQ(f->max_per_step, 1u);
      EXPECT_EQ(m.traffic.rounds[at(kind)], kN);
      // Larger than kSteps empty batches once something crossed.
      if (kind == MessageKind::Migrants)
        migrants_nonempty += f->bytes > kN * encoded_size(m.world, other, MigrantBatch{});
    }
    const MessageFlow* glue = find(m.traffic, other, MessageKind::Glue);
    ASSERT_TRUE(glue) << "world " << m.world << " sent no Glue";
    EXPECT_GT(glue->messages, 0u);
    EXPECT_LT(glue->messages, kN);
    EXPECT_EQ(glue->max_per_step, 1u);
    EXPECT_EQ(m.traffic.rounds[at(MessageKind::Glue)], glue->messages);  // one neighbour
    if (m.merged_islands) {
      EXPECT_GT(m.traffic.rounds[at(MessageKind::Fragments)], 0u);
    }
    merged += m.merged_islands;
    // An island over both worlds: a root and one child below it.
    EXPECT_EQ(m.traffic.island_depth_max, m.merged_island_worlds_max == 2 ? 1u : 0u);
    EXPECT_LE(m.traffic.island_depth_sum, kN);
    expect_sums(m);
    for (const MessageFlow& f : m.traffic.flows) bytes += f.bytes;
  }
  EXPECT_GT(merged, 0u);
  EXPECT_EQ(migrants_nonempty, 1u);  // the rolling sphere left world 0 once
  EXPECT_EQ(bytes, world->bytes_sent());
}

// Counts carried across a rebuild (load balancing) or summed over worlds.
TEST(MessageTraffic, AddMergesFlowsByDestinationAndKind) {
  MessageTally a, b;
  a.sent(1, MessageKind::Ghosts, 10);
  a.sent(1, MessageKind::Ghosts, 20);
  a.sent(3, MessageKind::Glue, 5);
  a.island_depth(2);
  a.end_step();
  b.sent(1, MessageKind::Ghosts, 7);
  b.sent(2, MessageKind::Migrants, 9);
  b.end_step();
  MessageTraffic t = a.totals();
  ASSERT_EQ(t.flows.size(), 2u);
  EXPECT_EQ(t.flows[0].max_per_step, 2u);
  EXPECT_EQ(t.rounds[at(MessageKind::Ghosts)], 2u);
  add_traffic(t, b.totals());
  ASSERT_EQ(t.flows.size(), 3u);
  EXPECT_EQ(t.flows[0].to, 1);
  EXPECT_EQ(t.flows[0].messages, 3u);
  EXPECT_EQ(t.flows[0].bytes, 37u);
  EXPECT_EQ(t.flows[0].steps, 2u);
  EXPECT_EQ(t.flows[0].max_per_step, 2u);
  EXPECT_EQ(t.flows[1].to, 2);
  EXPECT_EQ(t.flows[2].to, 3);
  EXPECT_EQ(t.rounds[at(MessageKind::Ghosts)], 3u);
  EXPECT_EQ(t.island_depth_max, 2u);
  EXPECT_EQ(t.island_depth_sum, 2u);
}

}  // namespace
}  // namespace soda
