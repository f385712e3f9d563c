// Internal: one world's speculation (docs/rollback.md), the Speculation a
// step (world_process.h) runs with anticipation > 0. It holds everything
// speculation needs — the bets, the log of the neighbours' messages used,
// the world's kept states (with the step's KeptStates), the old run a re-run
// may rejoin, the validation reports held until committed — and goes back
// in time through one verb family (docs/rollback.md, "Going back in time"),
// each deciding, in the hook's Verdict, what the step then does:
//
//   roll_back(t)     a used message of step t changed: this world's own
//                    rollback (restore + Notice to the neighbours), or a
//                    rollback of every world posted on the board
//   restore(t)       this world only: a restart from its kept state at t,
//                    the used messages put back in the inbox
//   catch_up()       take in the rollbacks of every world posted since
//   reset(t)         the run was rewound from outside (a Simulation's
//                    rollback for past inputs): forget everything past t
//   try_rejoin()     the re-run's state equals the old run's: take the old
//                    run's later steps back instead of re-running them
//
// It reads the step (const WorldStep&) as the verdict being built leaves it:
// at_step() and at_phase() are the step's after the restart decided so far.
// Why the result equals lockstep's and why it ends: anticipation.cpp.
// Used by the world's thread only (the hooks), except metrics().
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <tuple>
#include <utility>
#include <vector>

#include "step/kept_states.h"
#include "step/process_options.h"
#include "speculation/speculation.h"
#include "step/stage_clock.h"
#include "step/validator.h"
#include "step/world_step.h"

namespace soda {

/// SODA_SPEC_TRACE set: every rollback, notice and rejoin to stderr.
inline const bool kSpecTrace = std::getenv("SODA_SPEC_TRACE") != nullptr;
#define SPEC_TRACE(...)                                  \
  do {                                                   \
    if (::soda::kSpecTrace) std::fprintf(stderr, __VA_ARGS__); \
  } while (0)

/// A message of a merged island — Glue with entries, Fragments, Gather,
/// Results. A rollback over a step with one sent or used is a rollback of
/// every world. Ghosts, Migrants and empty Glue (no island crosses the
/// border) are kept when used and compared with their re-sends.
bool is_merge_message(const Message& m);

class Anticipation final : public Speculation {
 public:
  /// What the step shares with its speculation (every reference outlives it).
  struct Context {
    const WorldStep& step;
    KeptStates& kept;
    const ProcessSafety& safety;  // anticipation > 0
    const ProcessOutput& output;
    const std::vector<WorldId>& neighbours;
    Validator* validator;
    int substeps;
    StageClock& clock;
  };
  explicit Anticipation(Context context);

  // The hooks (speculation.h).
  Verdict catch_up() override;
  /// Drops a notice, a void message, a re-send compared with the one used,
  /// late glue.
  Verdict screen(Message& m) override;
  /// Bets on Ghosts or Migrants: Put edits of empty messages, or nothing.
  Verdict bet(MessageKind kind) override;
  /// A re-run step replays what comes out unchanged.
  Verdict before_predict() override;
  void used(const MessageKey& key, const Message& m) override;
  /// Logged for a rejoin; merge steps noted.
  void sent(const Message& m) override;
  void merged() override { merge_steps_.insert(s_.step); }
  /// Passed on to the validator once committed (GVT past it).
  void report(WorldStepReport report) override;
  /// Keeps the state, reports the low-water mark, trims what GVT passed,
  /// rejoins the old run if possible.
  Verdict step_ended(const TerritoryCounters& counters) override;
  /// Done once no step may still change (the world is woken when GVT
  /// reaches its clock).
  bool done() override;
  bool wake_when_final(std::int64_t scene_step) override;
  void published(std::int64_t scene_step) override;
  /// Under a Simulation: commit step and RunControl follow GVT.
  void report_committed() override;
  void step_cpu(std::int64_t ns) override;
  void reset(std::int64_t step) override;
  std::uint32_t epoch() const override { return seen_epoch_; }
  bool runs_ahead() const override { return true; }
  /// rollback_cpu_seconds: the re-runs only.
  void metrics(WorldMetrics& m) const override;
  /// Internal steps between kept states.
  int checkpoint_every() const { return checkpoint_every_; }

 private:
  // A neighbour's message this run used, kept while its step is above GVT.
  struct Used {
    std::uint64_t digest = 0;        // of the message's bytes, once unconfirmed
    bool confirmed = true;           // false: a bet not yet met, or void (re-send awaited)
    bool bet = false;                // assumed empty before it arrived
    std::optional<Message> message;  // for a re-run after this world rolls back
  };
  using UsedKey = std::tuple<std::int64_t, int, WorldId>;  // (step, kind, from)
  // What this world's run had done past a rollback of its own, kept while
  // the re-run may rejoin it: once the re-run's state at a step after the
  // message that changed is bit-equal to the old run's, and the messages the
  // old run used from there on are the ones at hand, the old run's later
  // steps are still exact (a step is a function of the state and the
  // messages used) and are taken back instead of re-run (try_rejoin).
  struct OldRun {
    std::int64_t changed_step = 0;                      // the step whose message changed
    std::map<std::int64_t, WorldSnapshot> kept;         // its states after the rollback's step
    std::map<UsedKey, Used> used;                       // messages it used from that step on
    std::map<std::int64_t, std::vector<Message>> sent;  // messages it sent from that step on
    std::map<std::int64_t, WorldStepReport> reports;    // validation reports after that step
    std::set<std::int64_t> merge_steps;                 // its steps with merge messages (never taken back)
    std::map<std::int64_t, LocalIslands> islands;       // the islands it solved in place, by step (arm_replay)
  };
  // The step a rollback interrupted after its islands were solved: what it
  // had solved, for the re-run of that step to replay (arm_replay).
  struct PartialStep {
    std::int64_t step = -1;
    bool integrated = false;  // state taken after integrate(), else right after the solve
    LocalIslands islands;
    WorldSnapshot state;
  };

  // The verdict a hook is building (set by the hook, null between hooks),
  // and the step as it leaves it.
  // Sets the verdict a hook builds (out_) for the hook's length.
  class Building {
   public:
    Building(Anticipation& a, Verdict& v) : a_(a) { a_.out_ = &v; }
    ~Building() { a_.out_ = nullptr; }
    Building(const Building&) = delete;
    Building& operator=(const Building&) = delete;

   private:
    Anticipation& a_;
  };
  Verdict& out();
  std::int64_t at_step() const;
  StepPhase at_phase() const;
  bool screen_into(Message& m);
  void catch_up_into();
  bool within_anticipation();
  bool compare_with_used(Message& m);
  void take_notice(WorldId from, std::int64_t step);
  void roll_back(std::int64_t step);
  std::int64_t checkpoint_at_or_before(std::int64_t step) const;
  void restore(std::int64_t step, std::int64_t changed_step, bool keep_old_run);
  void try_rejoin();
  bool may_rejoin(std::int64_t j, std::vector<std::pair<std::int64_t, const WorldSnapshot*>>& entries);
  void rejoin(std::int64_t j, const std::vector<std::pair<std::int64_t, const WorldSnapshot*>>& entries);
  void arm_replay();
  void drop_old_run();
  void await_resend(std::int64_t step, Used& u);
  void report_mark();
  void trim_below(std::int64_t gvt);
  WorldId me() const { return s_.world->id(); }

  Context c_;
  const WorldStep& s_;  // c_.step
  Verdict* out_ = nullptr;  // the verdict of the hook running
  int checkpoint_every_ = 1;  // keep a state every so many internal steps

  std::map<UsedKey, Used> used_;
  std::map<std::int64_t, int> unconfirmed_;                 // step -> unconfirmed uses
  std::set<MessageKey> bets_in_inbox_;
  std::set<MessageKey> lost_bets_;                          // never bet on these again
  std::map<WorldId, std::pair<std::int64_t, bool>> newest_ghosts_;  // per neighbour: step, not empty
  std::set<std::int64_t> merge_steps_;                      // steps with merge messages sent or used
  std::map<WorldId, std::uint64_t> notices_sent_;
  std::map<std::int64_t, WorldStepReport> reports_;         // validation: reported once committed
  std::map<std::int64_t, std::vector<Message>> sent_log_;   // Ghosts, Migrants, empty Glue sent, by step
  std::map<std::int64_t, LocalIslands> island_log_;         // islands solved in place, by step (propagate only)
  std::optional<OldRun> old_run_;
  std::optional<PartialStep> partial_step_;
  std::int64_t restored_to_ = -1;        // the step the newest restore went back to
  std::uint32_t seen_epoch_ = 0;         // of the rollback board
  std::int64_t reported_through_ = -1;   // validation: steps reported
  std::int64_t rerun_until_ = 0;         // steps below it are re-runs
  std::int64_t last_published_ = 0;      // newest scene step published
  std::int64_t committed_reported_ = 0;  // newest scene step reported to the RunControl

  // Metrics.
  std::uint64_t bets_ = 0, bets_lost_ = 0, rollbacks_ = 0, steps_rolled_back_ = 0, bodies_resolved_ = 0;
  std::uint64_t bodies_replayed_ = 0, steps_rejoined_ = 0;
  std::int64_t rerun_cpu_ns_ = 0;  // re-run steps, their restores excepted
  std::vector<std::int32_t> lead_;
};

}  // namespace soda
