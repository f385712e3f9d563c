// Messages: the byte encoding is exact and rejects malformed bytes with
// MessageFormatError; the world graph routes; the island merger completes
// islands from fragments alone; the validator names broken invariants.
#include <gtest/gtest.h>

#include <cstdio>
#include <memory>

#include "step/island_merge.h"
#include "runtime/partitioned_test_util.h"
#include "soda/runtime/message_codec.h"
#include "soda/runtime/transport.h"
#include "soda/runtime/world_graph.h"
#include "step/validator.h"

namespace soda {
namespace {

// A few bodies and manifolds of a settled pile, as values.
struct Values {
  std::vector<BodySnapshot> bodies;
  std::vector<ManifoldState> manifolds;
};

Values pile_values() {
  CanonicalWorld w(test::scene("cube-pile", 30));
  for (int i = 0; i < 60; ++i) w.step();
  WorldSnapshot s = w.snapshot();
  Values v;
  for (const BodySnapshot& b : s.bodies)
    if (!b.description.is_static) v.bodies.push_back(b);
  v.manifolds = s.manifolds;
  return v;
}

std::vector<Message> sample_messages() {
  const Values v = pile_values();
  std::vector<Message> out;
  GhostBatch g;
  for (std::size_t i = 0; i < 5; ++i) {
    BodyRecord r{v.bodies[i], {0, btScalar(-9.81), 0}, {btScalar(0.5), 0, btScalar(-0.25)}};
    g.ghosts.push_back(GhostRecord{r, {1, 3}});
  }
  g.kept_manifolds.assign(v.manifolds.begin(), v.manifolds.begin() + 3);
  out.push_back(Message{0, 1, 17, g});
  out.push_back(Message{1, 0, 17, GlueBatch{{{3, 1}, {4, 1}, {9, 2}}}});
  Fragment f;
  f.world = 2;
  f.root = 1;
  f.links_out = {{0, 7}, {3, 2}};
  f.links_in = {{1, 4, 5}};
  for (std::size_t i = 0; i < 3; ++i) f.bodies.push_back(BodyRecord{v.bodies[i], {1, 2, 3}, {4, 5, 6}});
  f.first_body = f.bodies.front().body.description.id;
  f.manifolds.assign(v.manifolds.begin(), v.manifolds.begin() + 4);
  f.weight = 3 + 4;  // bodies + manifolds
  out.push_back(Message{2, 3, 18, FragmentBatch{{f, f}}});
  const Scene joints = test::scene("ragdolls", 1);  // joints of every field the codec writes
  Fragment jointed = f;
  jointed.joints.assign(joints.joints.begin(), joints.joints.begin() + 3);
  out.push_back(Message{2, 3, 18, FragmentBatch{{jointed}}});
  MigrantBatch m;
  m.migrants.push_back(Migrant{v.bodies[0], {v.manifolds[0]}});
  m.migrants.push_back(Migrant{v.bodies[1], {}});
  out.push_back(Message{3, 2, 19, m});
  MigrantBatch jointed_migrants = m;
  jointed_migrants.joints = {JointSnapshot{joints.joints[0], false}, JointSnapshot{joints.joints[1], true}};
  out.push_back(Message{3, 2, 19, jointed_migrants});
  out.push_back(Message{3, 2, 20, MigrantBatch{}});
  IslandResult r;
  r.island = v.bodies[0].description.id;
  for (std::size_t i = 0; i < 4; ++i) {
    BodyResult b;
    b.id = v.bodies[i].description.id;
    b.linear_velocity[1] = btScalar(-0.5) * btScalar(i);
    b.origin[0] = btScalar(i);
    b.activation_state = i == 2 ? 3 : 1;
    b.deactivation_time = btScalar(0.25);
    r.bodies.push_back(b);
  }
  r.manifolds.assign(v.manifolds.begin(), v.manifolds.begin() + 2);
  out.push_back(Message{4, 1, 21, ResultBatch{{std::make_shared<const IslandResult>(r), std::make_shared<const IslandResult>(r)}}});
  IslandResult broke = r;
  broke.broken_joints = {3, 9};
  out.push_back(Message{4, 1, 21, ResultBatch{{std::make_shared<const IslandResult>(broke)}}});
  Fragment header{3, 2, kNoBody, 0, {{0, 2}}, {}, {}, {}, {}};  // only a ghost: no first body
  out.push_back(Message{1, 2, 22, GatherBatch{r.island, {f, header}}});
  return out;
}

TEST(MessageCodec, RoundTripIsExact) {
  std::uint32_t stamp = 0;
  for (Message m : sample_messages()) {
    m.epoch = stamp++;
    m.rewinds = 2 * stamp;
    const std::vector<std::uint8_t> bytes = encode_message(m);
    const Message back = decode_message(bytes);
    EXPECT_EQ(back.from, m.from);
    EXPECT_EQ(back.to, m.to);
    EXPECT_EQ(back.step, m.step);
    EXPECT_EQ(back.epoch, m.epoch);
    EXPECT_EQ(back.rewinds, m.rewinds);
    EXPECT_EQ(back.kind(), m.kind());
    EXPECT_EQ(encode_message(back), bytes) << describe(m);
    std::printf("[ codec %s ] %s: %zu bytes\n", kPrecisionName, describe(m).c_str(), bytes.size());
  }
}

// The digest speculation compares re-sent messages by: blind to the stamps
// (epoch, rewinds) only; any other field changes it.
TEST(MessageCodec, DigestLeavesOutTheStampsOnly) {
  const std::vector<Message> all = sample_messages();
  for (std::size_t i = 0; i < all.size(); ++i) {
    Message m = all[i];
    const std::uint64_t d = message_digest(m);
    m.epoch += 7;
    m.rewinds += 3;
    EXPECT_EQ(message_digest(m), d) << describe(m);
    m.step += 1;
    EXPECT_NE(message_digest(m), d) << describe(m);
    for (std::size_t j = 0; j < all.size(); ++j)
      if (j != i) {
        EXPECT_NE(message_digest(all[j]), d) << describe(all[i]) << " and " << describe(all[j]);
      }
  }
  Message g = all.front();
  std::get<GhostBatch>(g.payload).ghosts.front().record.body.state.origin[0] += btScalar(1);
  EXPECT_NE(message_digest(g), message_digest(all.front()));
}

TEST(MessageCodec, MalformedBytesThrow) {
  for (const Message& m : sample_messages()) {
    const std::vector<std::uint8_t> bytes = encode_message(m);
    for (std::size_t n = 0; n < bytes.size(); n += (n < 64 ? 1 : 5)) {
      const std::vector<std::uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
      EXPECT_THROW(decode_message(cut), MessageFormatError) << describe(m) << " truncated to " << n;
    }
    auto with = [&](std::size_t at, std::uint8_t value) {
      std::vector<std::uint8_t> b = bytes;
      b[at] = value;
      return b;
    };
    EXPECT_THROW(decode_message(with(0, 'X')), MessageFormatError);   // magic
    EXPECT_THROW(decode_message(with(8, 99)), MessageFormatError);    // version
    EXPECT_THROW(decode_message(with(12, 3)), MessageFormatError);    // precision
    EXPECT_THROW(decode_message(with(16, 0)), MessageFormatError);    // kind
    EXPECT_THROW(decode_message(with(16, 77)), MessageFormatError);   // kind
    EXPECT_THROW(decode_message(with(20, 0xff)), MessageFormatError); // negative sender
    std::vector<std::uint8_t> longer = bytes;
    longer.push_back(0);
    EXPECT_THROW(decode_message(longer), MessageFormatError);         // trailing
    // Any single corrupted byte: it decodes or it throws, nothing else.
    for (std::size_t at = 0; at < bytes.size(); at += 7) {
      try {
        (void)decode_message(with(at, static_cast<std::uint8_t>(bytes[at] ^ 0x5a)));
      } catch (const MessageFormatError&) {
      }
    }
  }
  // A fragment whose weight is not its bodies + manifolds (the root rule
  // reads the weight of fragments whose data it never sees).
  for (const Message& m : sample_messages()) {
    if (m.kind() != MessageKind::Fragments) continue;
    Message wrong = m;
    std::get<FragmentBatch>(wrong.payload).fragments.front().weight += 1;
    EXPECT_THROW(decode_message(encode_message(wrong)), MessageFormatError);
  }
  try {
    (void)decode_message(std::vector<std::uint8_t>(10, 0));
    ADD_FAILURE() << "no exception";
  } catch (const MessageFormatError& e) {
    std::printf("[ codec %s ] malformed: %s\n", kPrecisionName, e.what());
    EXPECT_NE(std::string(e.what()).find("decode_message"), std::string::npos);
  }
}

TEST(Transport, QueuesInOrderAndSerialises) {
  for (bool serialise : {false, true}) {
    auto t = serialise ? make_serialising_transport(3) : make_in_memory_transport(3);
    const std::vector<Message> ms = sample_messages();
    for (Message m : ms) {
      m.to = 2;
      t->send(2, m);
    }
    EXPECT_FALSE(t->try_receive(1).has_value());
    for (const Message& m : ms) {
      const std::optional<Message> r = t->try_receive(2);
      ASSERT_TRUE(r.has_value());
      EXPECT_EQ(r->step, m.step);
      EXPECT_EQ(r->kind(), m.kind());
    }
    EXPECT_FALSE(t->try_receive(2).has_value());
    EXPECT_EQ(t->messages_sent(), ms.size());
    EXPECT_EQ(t->bytes_sent() > 0, serialise);
    EXPECT_THROW(t->send(5, Message{0, 5, 0, GlueBatch{}}), std::out_of_range);
    EXPECT_THROW(t->send(1, Message{0, 2, 0, GlueBatch{}}), std::invalid_argument);
  }
}

TEST(WorldGraph, NextHopAlongAStrip) {
  const Scene s = test::scene("chain", 16);
  GridOptions g;
  g.cell_size = 2.0;
  g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  const WorldGraph graph(make_partition("grid:8x1x1", s, 8, g));
  EXPECT_EQ(graph.diameter(), 7);
  EXPECT_EQ(graph.neighbours(3), (std::vector<WorldId>{2, 4}));
  EXPECT_TRUE(graph.adjacent(0, 1));
  EXPECT_FALSE(graph.adjacent(0, 2));
  EXPECT_EQ(graph.next_hop(0, 7), 1);
  EXPECT_EQ(graph.next_hop(7, 0), 6);
  EXPECT_EQ(graph.next_hop(4, 4), 4);
  EXPECT_EQ(graph.distance(1, 6), 5);
}

// Fragments of one island along worlds 0 - 1 - 2 (ghost links), merged by
// hand-carried messages: every world completes the same island.
TEST(IslandMerger, CompletesAnIslandAcrossThreeWorlds) {
  // World 0 holds a ghost of body 20 (owned by 1); world 1's fragment
  // {20, ghost 30} is glued by 0 and holds a ghost of 30 (owned by 2), which
  // world 2's fragment {30} is glued by.
  Fragment f0{0, 10, 10, 1, {{1, 20}}, {}, {}, {}, {}};
  Fragment f1{1, 20, 20, 1, {{2, 30}}, {{0, 10, 20}}, {}, {}, {}};
  Fragment f2{2, 30, 30, 1, {}, {{1, 20, 30}}, {}, {}, {}};
  IslandMerger m[3];
  m[0].start(0, {f0}, false);
  m[1].start(1, {f1}, false);
  m[2].start(2, {f2}, false);
  for (int round = 0; round < 4; ++round) {
    std::vector<std::tuple<int, int, std::vector<Fragment>>> mail;
    for (int w = 0; w < 3; ++w)
      for (auto& [to, fs] : m[w].take_outgoing()) mail.emplace_back(w, to, std::move(fs));
    for (auto& [from, to, fs] : mail) m[to].receive(from, std::move(fs));
  }
  for (int w = 0; w < 3; ++w) {
    EXPECT_TRUE(m[w].done()) << "world " << w;
    const auto closed = m[w].take_closed();
    ASSERT_EQ(closed.size(), 1u) << "world " << w;
    ASSERT_EQ(closed[0].size(), 3u);
    EXPECT_EQ(closed[0][0]->root, 10u);
    EXPECT_EQ(closed[0][2]->root, 30u);
  }
  EXPECT_GT(m[1].fragments_relayed(), 0u);  // world 1 passes 0's fragment on to 2 and back
}

// A root takes its own fragments' data out of the merger instead of copying
// it (world_merge.cpp): only once the island is closed, only without
// carry_data; the closed island keeps every fragment's header.
TEST(IslandMerger, TakeMineMovesThisWorldsDataOutOfAClosedIsland) {
  Fragment f0{0, 10, 10, 2, {{1, 20}}, {}, {}, {}, {}};
  f0.manifolds.push_back(ManifoldState{10, 20, {ContactPointState{}}});
  Fragment f1{1, 20, 20, 1, {}, {{0, 10, 20}}, {}, {}, {}};
  IslandMerger m0, m1;
  m0.start(0, {f0}, false);
  m1.start(1, {f1}, false);
  for (int round = 0; round < 3; ++round) {
    for (auto& [to, fs] : m0.take_outgoing()) m1.receive(0, std::move(fs));
    for (auto& [to, fs] : m1.take_outgoing()) m0.receive(1, std::move(fs));
  }
  const auto closed = m0.take_closed();
  ASSERT_EQ(closed.size(), 1u);
  const std::vector<Fragment> mine = m0.take_mine(closed[0]);
  ASSERT_EQ(mine.size(), 1u);
  EXPECT_EQ(mine[0].root, 10u);
  ASSERT_EQ(mine[0].manifolds.size(), 1u);
  EXPECT_EQ(mine[0].manifolds[0].points.size(), 1u);
  ASSERT_EQ(mine[0].links_out.size(), 1u);
  // The merger's copy keeps the header, not the data.
  EXPECT_EQ(closed[0][0]->root, 10u);
  EXPECT_EQ(closed[0][0]->links_out.size(), 1u);
  EXPECT_TRUE(closed[0][0]->manifolds.empty());

  IslandMerger carrying;
  carrying.start(0, {f0}, true);
  EXPECT_THROW(carrying.take_mine({}), std::logic_error);
}

TEST(Validator, NamesBrokenInvariants) {
  const Scene s = test::scene("falling-cubes", 4);  // ground 0, cubes 1..4
  Validator ok(s, 2);
  ok.report(WorldStepReport{0, 1, {1, 2}, 0, 1, 3, {{1, 2}}});
  ok.report(WorldStepReport{1, 1, {3, 4}, 1, 1, 4, {{3, 4}}});
  EXPECT_EQ(ok.steps_checked(), 1);
  Validator twice(s, 2);
  twice.report(WorldStepReport{0, 5, {1, 2, 3}, 0, 1, 4, {}});
  try {
    twice.report(WorldStepReport{1, 5, {3, 4}, 0, 1, 3, {}});
    ADD_FAILURE() << "no exception";
  } catch (const ValidationError& e) {
    std::printf("[ validator ] %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find("body 3 is owned by worlds 0 1"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("step 5"), std::string::npos);
  }
  Validator lost(s, 2);
  lost.report(WorldStepReport{0, 2, {1}, 0, 1, 2, {{0, 1}}});
  EXPECT_THROW(lost.report(WorldStepReport{1, 2, {3, 4}, 0, 1, 5, {{0, 1}}}), ValidationError);  // 2 lost, pair
                                                                                                   // held twice,
                                                                                                   // count wrong
  // Parked bodies are owned but out of the Bullet world: the count allows
  // for them, and no more of them than bodies owned.
  Validator parked(s, 2);
  parked.report(WorldStepReport{0, 3, {1, 2}, 0, 1, 2, {}, 1});  // one parked: 1 owned + 1 static in Bullet
  EXPECT_THROW(parked.report(WorldStepReport{1, 3, {3, 4}, 0, 1, 3, {}, 1}), ValidationError);  // 3 != 1 + 1
  Validator too_many(s, 2);
  too_many.report(WorldStepReport{0, 4, {1, 2}, 0, 1, 3, {}, 0});
  EXPECT_THROW(too_many.report(WorldStepReport{1, 4, {3, 4}, 0, 1, 0, {}, 3}), ValidationError);  // 3 parked of 2
}

// Over ranks (gathered): each rank's validator holds its worlds' reports
// without checking; the union of every rank's, given to each, is checked
// step by step in order, once every world has reported the step; a step
// still owed waits for the next gather. A rank built from its share learns
// the other bodies from expect_bodies, or they would be "not in the scene".
TEST(Validator, GatheredOverRanksChecksTheUnionOfEveryRanksReports) {
  const Scene s = test::scene("falling-cubes", 4);  // ground 0, cubes 1..4
  Scene share = s;
  share.bodies.resize(3);  // rank 0 holds cubes 1 and 2
  const auto ranks = [&] {
    std::vector<std::unique_ptr<Validator>> v;
    for (int r = 0; r < 2; ++r) {
      v.push_back(std::make_unique<Validator>(share, 2, true));
      v.back()->expect_bodies({1, 2, 3, 4});
    }
    return v;
  };
  const auto gather = [](std::vector<std::unique_ptr<Validator>>& v) {
    std::vector<WorldStepReport> all;
    for (auto& r : v)
      for (WorldStepReport& report : r->take_pending()) all.push_back(std::move(report));
    for (auto& r : v) r->check_gathered(all);
  };
  auto ok = ranks();
  ok[0]->report(WorldStepReport{0, 1, {1, 2}, 0, 1, 3, {{1, 2}}});
  ok[1]->report(WorldStepReport{1, 1, {3, 4}, 1, 1, 4, {{3, 4}}});
  ok[0]->report(WorldStepReport{0, 2, {1, 2}, 0, 1, 3, {}});  // world 1 owes step 2
  EXPECT_EQ(ok[0]->steps_checked(), 0);  // a rank alone checks nothing
  gather(ok);
  EXPECT_EQ(ok[0]->steps_checked(), 1);
  EXPECT_EQ(ok[1]->steps_checked(), 1);
  ok[1]->report(WorldStepReport{1, 2, {3, 4}, 0, 1, 3, {}});
  gather(ok);
  EXPECT_EQ(ok[0]->steps_checked(), 2);
  auto twice = ranks();
  twice[0]->report(WorldStepReport{0, 5, {1, 2, 3}, 0, 1, 4, {}});
  twice[1]->report(WorldStepReport{1, 5, {3, 4}, 0, 1, 3, {}});
  std::vector<WorldStepReport> all = twice[1]->take_pending();
  for (WorldStepReport& r : twice[0]->take_pending()) all.push_back(std::move(r));
  for (auto& v : twice) {  // each rank fails alike, with the same message
    try {
      v->check_gathered(all);
      ADD_FAILURE() << "no exception";
    } catch (const ValidationError& e) {
      EXPECT_NE(std::string(e.what()).find("body 3 is owned by worlds 0 1"), std::string::npos) << e.what();
    }
  }
  Validator unaware(share, 2, true);  // not told of cubes 3 and 4
  EXPECT_THROW(unaware.check_gathered({WorldStepReport{0, 1, {1, 2}, 0, 1, 3, {}},
                                       WorldStepReport{1, 1, {3, 4}, 0, 1, 3, {}}}),
               ValidationError);
}

}  // namespace
}  // namespace soda
