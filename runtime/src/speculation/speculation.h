// Internal: how a world's step (world_process.h) treats time — the
// component the step asks, at fixed hooks, what to do about its neighbours'
// messages and its own past. Two implementations: Lockstep (lockstep.h),
// which waits for every message and never goes back, every hook a no-op;
// and Anticipation (anticipation.h, docs/rollback.md), which bets on empty
// messages, runs ahead and goes back when a bet is lost.
//
// Speculation decides; the step applies. A hook returns a Verdict — drop or
// accept a message, messages to put in the inbox or take out of it, a
// restart at an earlier step (or, rejoining, a later one) from a kept state,
// messages to send — and only the world's process changes its inbox, its
// merge queue, its phase and its world (Process::apply, world_process.cpp).
// A speculation reads the step (const WorldStep&), never writes it.
//
// Invariants:
//  1. a verdict is applied whole, before the step reads its inbox again:
//     inbox edits in order, then the restart (the last one decided: a
//     restart forgets nothing of the inbox, and a later restart replaces an
//     earlier one), then the entries the buffer drops, the messages sent,
//     the backlog of entries to publish first and the replay to arm;
//  2. the state a restart names stays valid until the verdict is applied
//     (it is a kept state no later decision of the same hook drops);
//  3. Lockstep's verdicts are empty, its screen accepts every message and
//     its done() is true: the step without speculation is the step.
#pragma once

#include <cstdint>
#include <optional>
#include <set>
#include <utility>
#include <vector>

#include "soda/rollback/transform_buffer.h"
#include "soda/runtime/messages.h"
#include "soda/runtime/world_metrics.h"
#include "soda/worlds/territory_world.h"
#include "step/validator.h"
#include "step/world_step.h"

namespace soda {

/// One change to a step's inbox (and its merge queue, `fragments`).
struct InboxEdit {
  enum class Kind {
    Put,       // `message` under `key`
    Erase,     // the message under `key`, if any
    DropFrom,  // every message of world `from` at steps >= `step`, inbox and merge queue
    DropVoid,  // every message of an epoch below `epoch` at steps >= `step`, but those under `keep`
  };
  Kind kind = Kind::Put;
  MessageKey key{};
  Message message{};
  WorldId from = kNoWorld;
  std::int64_t step = 0;
  std::uint32_t epoch = 0;
  std::set<MessageKey> keep{};
};

/// What a speculation decided at one hook (invariant 1: how it is applied).
struct Verdict {
  /// screen(): the message is taken care of; the step drops it.
  bool drop = false;
  std::vector<InboxEdit> inbox;
  /// The step begins again at internal step `step` (its Predict) in the
  /// world rebuilt from `state` (a kept state: invariant 2).
  struct Restart {
    std::int64_t step = 0;
    const WorldSnapshot* state = nullptr;
  };
  std::optional<Restart> restart;
  /// Under a Simulation: the transform buffer's entries from this scene step
  /// on are void (republished by the re-run); -1: none.
  std::int64_t republish_from = -1;
  /// Messages to send after the restart, stamped by the step (notices).
  std::vector<std::pair<WorldId, Message>> send;
  /// Messages to send again exactly as they were sent (a rejoin).
  std::vector<Message> resend;
  /// Entries to publish before the step goes on (a rejoin took these scene
  /// steps back); the step is then in its Publish phase.
  std::vector<TransformEntry<btScalar>> backlog;
  /// Islands the next step replays (TerritoryWorld::set_replay).
  std::optional<StepReplay> replay;

  bool empty() const {
    return !drop && inbox.empty() && !restart && republish_from < 0 && send.empty() && resend.empty() &&
           backlog.empty() && !replay;
  }
};

class Speculation {
 public:
  virtual ~Speculation() = default;

  // Hooks, in the order of a step.
  /// advance(), first: rollbacks of every world not taken in yet.
  virtual Verdict catch_up() = 0;
  /// A message delivered (drop: taken care of here — a notice, a void
  /// message, a re-send compared with the one used, late glue). A message
  /// dropped may have been moved from.
  virtual Verdict screen(Message& m) = 0;
  /// A neighbour's `kind` of this step missing: bets that it is empty
  /// (Put edits), or nothing.
  virtual Verdict bet(MessageKind kind) = 0;
  /// Before predict(): what a re-run step replays.
  virtual Verdict before_predict() = 0;
  /// A neighbour's message taken from the inbox for the step.
  virtual void used(const MessageKey& key, const Message& m) = 0;
  /// A message this world sends (stamped: step, epoch()).
  virtual void sent(const Message& m) = 0;
  /// A merge message of this step taken in.
  virtual void merged() = 0;
  /// Validation: the report of the step just finished.
  virtual void report(WorldStepReport report) = 0;
  /// After each internal step's end: keep the state, report the low-water
  /// mark, maybe rejoin an old run.
  virtual Verdict step_ended(const TerritoryCounters& counters) = 0;
  /// The world reached its target: done unless a step may still change.
  virtual bool done() = 0;
  /// Asks the horizon to wake this world once scene step `scene_step` is
  /// final; false (and no wake) if it is already (readers' holds while
  /// speculating: RunControl::held_until).
  virtual bool wake_when_final(std::int64_t scene_step) = 0;
  /// An entry of scene step `scene_step` is in the transform buffer.
  virtual void published(std::int64_t scene_step) = 0;
  /// Under a Simulation, after each advance(): what is committed.
  virtual void report_committed() = 0;
  /// The CPU time of a finished step, its restores excepted.
  virtual void step_cpu(std::int64_t ns) = 0;
  /// The run was rewound to internal step `step` from outside.
  virtual void reset(std::int64_t step) = 0;
  /// The epoch of the rollback board taken in (messages carry it).
  virtual std::uint32_t epoch() const = 0;
  /// True if this world may run ahead of the commit horizon (its lead is
  /// measured and its waits name the horizon).
  virtual bool runs_ahead() const = 0;
  /// Fills the speculation fields of `m`.
  virtual void metrics(WorldMetrics& m) const = 0;
};

}  // namespace soda
