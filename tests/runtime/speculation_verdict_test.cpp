// Speculation decides, the step applies (runtime/src/speculation/speculation.h): the
// two implementations driven hook by hook on one thread, with a real
// territory world, commit horizon and rollback board, and no process — the
// test reads each Verdict and applies its inbox edits by hand.
//  - Lockstep: every verdict empty, every message accepted, done at once;
//  - Anticipation: a missing neighbour's Ghosts is bet on (a Put of an empty
//    batch); the same message arriving confirms the bet (dropped, no
//    restart); a different one loses it: a restart at the checkpoint, a
//    notice to the neighbour, the message accepted for the re-run; a notice
//    from the neighbour drops its messages of later steps; a bet is never
//    placed past the anticipation.
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "speculation/anticipation.h"
#include "speculation/lockstep.h"
#include "soda/grid/partition.h"
#include "soda/rollback/commit_horizon.h"
#include "soda/rollback/rollback_board.h"
#include "soda/scene/registry.h"

namespace soda {
namespace {

struct Bench {
  Scene scene = make_scene("falling-cubes", SceneParams{40, 1, false});
  TerritoryMap map = make_partition("grid:2x1x1", scene, 2, GridOptions{});
  TerritoryWorld world{scene, 0, map};
  WorldStep step;
  KeptStates kept;
  SharedMemoryHorizon horizon{2, 0};
  RollbackBoard board{2, horizon, [](WorldId) {}};
  ProcessSafety safety;
  ProcessOutput output;
  std::vector<WorldId> neighbours{1};
  StageClock clock;

  explicit Bench(int anticipation) {
    step.world = &world;
    kept.keep(0, world);
    safety.horizon = &horizon;
    safety.board = &board;
    safety.anticipation = anticipation;
    safety.checkpoint_every = 1;
  }
  std::unique_ptr<Anticipation> anticipation() {
    return std::make_unique<Anticipation>(
        Anticipation::Context{step, kept, safety, output, neighbours, nullptr, 1, clock});
  }
  // The inbox edits of a verdict, as the process applies them.
  void apply_inbox(Verdict& v) {
    for (InboxEdit& e : v.inbox) {
      if (e.kind == InboxEdit::Kind::Put) step.inbox.emplace(e.key, e.message);
      if (e.kind == InboxEdit::Kind::Erase) step.inbox.erase(e.key);
      if (e.kind == InboxEdit::Kind::DropFrom)
        std::erase_if(step.inbox, [&](const auto& in) {
          return std::get<2>(in.first) == e.from && std::get<1>(in.first) >= e.step;
        });
    }
  }
};

Message ghosts_from(WorldId from, std::int64_t step, bool empty) {
  Message m;
  m.from = from;
  m.to = 0;
  m.step = step;
  GhostBatch b;
  if (!empty) {
    GhostRecord g;
    g.record.body.description.id = 12345;
    b.ghosts.push_back(g);
  }
  m.payload = b;
  return m;
}

// World `from`'s first Notice to world 0: it rolled back to `step`, its
// pin held there.
Message notice_from(WorldId from, std::int64_t step) {
  Message m;
  m.from = from;
  m.to = 0;
  m.payload = Control{Control::Type::Notice, 1, step, step};
  return m;
}

TEST(SpeculationVerdict, LockstepDecidesNothing) {
  Bench b(0);
  Lockstep lockstep(Lockstep::Context{b.step, b.kept, b.safety, b.output, nullptr, 1, b.clock});
  Message m = ghosts_from(1, 0, false);
  EXPECT_TRUE(lockstep.catch_up().empty());
  EXPECT_TRUE(lockstep.screen(m).empty());
  EXPECT_TRUE(lockstep.bet(MessageKind::Ghosts).empty());
  EXPECT_TRUE(lockstep.before_predict().empty());
  EXPECT_TRUE(lockstep.step_ended(TerritoryCounters{}).empty());
  EXPECT_TRUE(lockstep.done());
  EXPECT_FALSE(lockstep.runs_ahead());
  EXPECT_EQ(lockstep.epoch(), 0u);
}

TEST(SpeculationVerdict, ABetMetIsDroppedWithoutARestart) {
  Bench b(8);
  auto spec = b.anticipation();
  Verdict bet = spec->bet(MessageKind::Ghosts);
  ASSERT_EQ(bet.inbox.size(), 1u);
  EXPECT_EQ(bet.inbox[0].kind, InboxEdit::Kind::Put);
  EXPECT_EQ(bet.inbox[0].key, message_key(MessageKind::Ghosts, 0, 1));
  EXPECT_TRUE(std::get<GhostBatch>(bet.inbox[0].message.payload).ghosts.empty());
  EXPECT_FALSE(bet.restart);
  b.apply_inbox(bet);
  // The step takes it (take_all), then the real message arrives: the same.
  const MessageKey key = message_key(MessageKind::Ghosts, 0, 1);
  spec->used(key, b.step.inbox.at(key));
  b.step.inbox.erase(key);
  Message same = ghosts_from(1, 0, true);
  Verdict v = spec->screen(same);
  EXPECT_TRUE(v.drop);
  EXPECT_FALSE(v.restart);
  EXPECT_TRUE(v.send.empty());
  WorldMetrics m;
  spec->metrics(m);
  EXPECT_EQ(m.bets, 1u);
  EXPECT_EQ(m.bets_lost, 0u);
  EXPECT_EQ(m.rollbacks, 0u);
}

TEST(SpeculationVerdict, ABetLostRestartsAtTheCheckpointAndNotifies) {
  Bench b(8);
  auto spec = b.anticipation();
  Verdict bet = spec->bet(MessageKind::Ghosts);
  b.apply_inbox(bet);
  const MessageKey key = message_key(MessageKind::Ghosts, 0, 1);
  spec->used(key, b.step.inbox.at(key));
  b.step.inbox.erase(key);
  b.step.phase = StepPhase::AwaitGlue;  // the step went on with its bet
  Message other = ghosts_from(1, 0, false);
  Verdict v = spec->screen(other);
  EXPECT_FALSE(v.drop);  // the re-run uses it: the step puts it in its inbox
  ASSERT_TRUE(v.restart);
  EXPECT_EQ(v.restart->step, 0);
  EXPECT_EQ(v.restart->state, &b.kept.states().at(0));
  ASSERT_EQ(v.send.size(), 1u);
  EXPECT_EQ(v.send[0].first, 1);
  const Control& notice = std::get<Control>(v.send[0].second.payload);
  EXPECT_EQ(notice.type, Control::Type::Notice);
  EXPECT_EQ(notice.rolled_to, 0);
  WorldMetrics m;
  spec->metrics(m);
  EXPECT_EQ(m.bets_lost, 1u);
  EXPECT_EQ(m.rollbacks, 1u);
  // The lost bet is not placed again at that step.
  b.step.phase = StepPhase::Predict;
  EXPECT_TRUE(spec->bet(MessageKind::Ghosts).empty());
}

TEST(SpeculationVerdict, ANoticeDropsTheNeighboursLaterMessages) {
  Bench b(8);
  auto spec = b.anticipation();
  Message later = ghosts_from(1, 3, false);
  b.step.inbox.emplace(message_key(MessageKind::Ghosts, 3, 1), later);
  Message before = ghosts_from(1, 0, false);
  b.step.inbox.emplace(message_key(MessageKind::Ghosts, 0, 1), before);
  ASSERT_TRUE(b.horizon.try_pin(2));
  Message notice = notice_from(1, 2);
  Verdict v = spec->screen(notice);
  EXPECT_TRUE(v.drop);
  EXPECT_FALSE(v.restart);
  b.apply_inbox(v);
  EXPECT_EQ(b.step.inbox.count(message_key(MessageKind::Ghosts, 3, 1)), 0u);
  EXPECT_EQ(b.step.inbox.count(message_key(MessageKind::Ghosts, 0, 1)), 1u);
}

Message glue_from(WorldId from, std::int64_t step, bool empty) {
  Message m;
  m.from = from;
  m.to = 0;
  m.step = step;
  GlueBatch b;
  if (!empty) b.entries.push_back(GlueEntry{12345, 12345});
  m.payload = b;
  return m;
}

// This world used world 1's empty Glue of step 0 and is merging that step;
// then world 1's Notice voids its messages from step 0 on (the empty Glue
// awaits its re-send).
std::unique_ptr<Anticipation> merging_with_a_voided_empty_glue(Bench& b) {
  auto spec = b.anticipation();
  const MessageKey key = message_key(MessageKind::Glue, 0, 1);
  b.step.inbox.emplace(key, glue_from(1, 0, true));
  spec->used(key, b.step.inbox.at(key));
  b.step.inbox.erase(key);
  b.step.phase = StepPhase::Merging;  // past its glue, merging the islands of step 0
  EXPECT_TRUE(b.horizon.try_pin(0));
  Message notice = notice_from(1, 0);
  Verdict n = spec->screen(notice);
  EXPECT_TRUE(n.drop);
  EXPECT_FALSE(n.restart);
  b.apply_inbox(n);
  return spec;
}

// The neighbour's first run of step 0 found no island across the border
// (its Glue empty, used here), then it rolled back on its own (a bet lost)
// and its re-run found one: the Glue it sends again holds entries. This
// world, past its glue, must compare it with the empty one it used and
// re-run step 0 with it. Dropped as "glue no longer waited for", the
// neighbour's fragment links to a body of this world that never takes part
// in the merge, and the neighbours wait for each other for good.
TEST(SpeculationVerdict, AGlueWithEntriesSentAgainForAnEmptyOneRestarts) {
  Bench b(8);
  auto spec = merging_with_a_voided_empty_glue(b);
  Message again = glue_from(1, 0, false);
  Verdict v = spec->screen(again);
  EXPECT_FALSE(v.drop);  // the re-run of step 0 uses it
  ASSERT_TRUE(v.restart);
  EXPECT_EQ(v.restart->step, 0);
  WorldMetrics m;
  spec->metrics(m);
  EXPECT_EQ(m.rollbacks, 1u);
}

// The same Glue sent again, empty: confirmed, no restart.
TEST(SpeculationVerdict, AnEmptyGlueSentAgainUnchangedIsConfirmed) {
  Bench b(8);
  auto spec = merging_with_a_voided_empty_glue(b);
  Message again = glue_from(1, 0, true);
  Verdict v = spec->screen(again);
  EXPECT_TRUE(v.drop);
  EXPECT_FALSE(v.restart);
}

TEST(SpeculationVerdict, NoBetPastTheAnticipation) {
  Bench b(2);
  auto spec = b.anticipation();
  b.step.step = 2;  // GVT 0: steps 0 and 1 are within an anticipation of 2
  EXPECT_TRUE(spec->bet(MessageKind::Ghosts).empty());
  b.step.step = 1;
  EXPECT_EQ(spec->bet(MessageKind::Ghosts).inbox.size(), 1u);
}

}  // namespace
}  // namespace soda
