// Internal: one world's side of the partitioned step — the step as a state
// machine over the TerritoryWorld's stages, waiting only for its neighbours'
// messages of the step. advance() runs as far as the messages at hand allow
// and never blocks, so the same machine runs under the round-robin driver,
// on a thread of its own (blocking on its mailbox between advances) or as a
// task of a pool (parked between advances).
//
//   Predict        predict; send Ghosts(t) to every neighbour
//   AwaitGhosts    <- Ghosts(t) from every neighbour; collide; build_islands;
//                  send Glue(t) to every neighbour that sent ghosts
//   AwaitGlue      <- Glue(t) from every neighbour ghosts were sent to;
//                  border fragments; start merging
//   Merging        <- Fragments(t) (headers) until every own island is
//                  complete; then the island's data climbs its tree
//                  (Gather(t), each world once its children's arrived) to
//                  the root (owner of its smallest body), which solves it;
//                  Results(t) descend the tree, each world keeping its part.
//                  Then integrate; migrate: send Migrants(t) to every
//                  neighbour
//   AwaitMigrants  <- Migrants(t) from every neighbour; absorb; step t done
//   Publish        (Simulation only, after each scene step) the owned bodies'
//                  poses to the world's transform buffer; waits while it is
//                  full (advance() returns, waiting_for_room() is true)
//
// Speculation (Safety::anticipation > 0; docs/rollback.md): a world missing
// a neighbour's Ghosts(t) or Migrants(t) bets that they are empty when it sent
// that neighbour no ghosts at t (so the neighbour cannot glue or merge with it
// at t), as long as t is within `anticipation` steps of the commit horizon.
// It keeps its state every checkpoint_every steps from the horizon on and
// the neighbours' messages it used. A message that differs from the one used
// (a lost bet, a message re-sent after its sender rolled back) rolls it back
// to that step: it rebuilds itself from the kept state and re-runs. If it had
// sent or used no merge message (is_merge_message) from that step on, the
// rollback is its own: it tells its neighbours (Notice: my messages of steps
// >= t sent before this are void), which keep the Ghosts, Migrants and empty
// Glue they used and compare them with the re-sent ones — only a difference
// rolls them back (Rollback and Propagate) — and its re-run rejoins the run
// it left once its state is bit-equal to that run's again (try_rejoin).
// Otherwise every world of the merged islands
// must re-merge, and the rollback is posted for every world at once
// (rollback_board.h). Safety::recompute posts every rollback for every world
// (discard and recompute, the baseline).
//
// Under PartitionedWorld::step the world runs up to a fixed target; under a
// Simulation (attach()) it asks the RunControl before beginning each step.
#pragma once

#include <atomic>
#include <deque>
#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <tuple>
#include <vector>

#include "commit_horizon.h"
#include "input_queue.h"
#include "island_merge.h"
#include "rollback_board.h"
#include "soda/rollback/transform_buffer.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/transport.h"
#include "testing_hooks.h"
#include "validator.h"

namespace soda {

class RunControl;

/// Speculation: a message of a merged island — Glue with entries, Fragments,
/// Gather, Results. A rollback over a step with one sent or used is a
/// rollback of every world. Ghosts, Migrants and empty Glue (no island
/// crosses the border) are kept when used and compared with their re-sends.
inline bool is_merge_message(const Message& m) {
  switch (m.kind()) {
    case MessageKind::Glue: return !std::get<GlueBatch>(m.payload).entries.empty();
    case MessageKind::Fragments:
    case MessageKind::Gather:
    case MessageKind::Results: return true;
    default: return false;
  }
}

class PartitionedWorld::Process {
 public:
  /// The watchdog, the injected fault and the rollback ring (options of the
  /// PartitionedWorld; pointers outlive the process).
  struct Safety {
    const WatchdogConfig* watchdog = nullptr;
    detail::InjectedFault fault = {};
    std::atomic<bool>* fault_fired = nullptr;
    CommitHorizon* horizon = nullptr;  // reported at every scene step boundary
    bool keep_states = false;          // keep the world's state at every boundary >= GVT
    FuzzRandom* fuzz = nullptr;        // fuzzing: a random pause before every stage
    int anticipation = 0;              // speculation: internal steps past the horizon; 0: off
    int checkpoint_every = 1;          // speculation: internal steps between kept states
    bool recompute = false;            // speculation: discard and recompute instead of propagate
    bool eager_bets = false;           // speculation: bet on neighbours whose newest ghosts were not empty
    bool verify_replay = false;        // speculation: solve replayed islands anyway and compare
    RollbackBoard* board = nullptr;    // speculation: rollbacks of every world
    /// Speculation: replaces this world by one rebuilt from its own part of
    /// the state (as kept) at an internal step boundary; returns it.
    std::function<TerritoryWorld&(const WorldSnapshot&, std::int64_t)> rebuild;
  };
  Process(TerritoryWorld& world, Transport& transport, const WorldGraph& graph, Validator* validator,
          std::function<void(std::int64_t)> progress, int substeps, bool solve_everywhere, Safety safety);

  /// Safety.keep_states: this world's part of the scene's state at scene step
  /// boundary `scene_step`, if still kept (kept from GVT to the world's clock).
  const WorldSnapshot* kept_state(std::int64_t scene_step) const;

  /// Run until `internal_steps` steps are done.
  void set_target(std::int64_t internal_steps) { target_ = internal_steps; }

  /// What a Simulation adds: the step limit comes from `control` (asked
  /// before each step begins); after each scene step `after_step` runs and
  /// the poses go to `buffer` as (scene step, scene step * dt).
  struct Output {
    RunControl* control = nullptr;
    TransformBuffer<btScalar>* buffer = nullptr;
    double dt = 0;
    std::function<void(WorldId, std::int64_t)> after_step;
    InputQueue* inputs = nullptr;  // user inputs, applied at each scene step boundary
    /// A rollback pending for this world (RunControl::take_rewind): on the
    /// world's own thread, rebuild the world from the state and rewind().
    std::function<void(const WorldSnapshot&)> rewind;
  };
  /// Before the first advance().
  void attach(Output output) { output_ = std::move(output); }
  /// True when the world stopped because its transform buffer is full (the
  /// Publish stage): it goes on once a reader frees an entry, or the buffer
  /// is stopped (the entry is then dropped).
  bool waiting_for_room() const { return phase_ == Phase::Publish; }
  /// Publish stage on a thread of the world's own: waits for room (blocking
  /// in TransformBuffer::publish), publishes or drops the entry.
  void publish_blocking();
  /// Internal steps done.
  std::int64_t steps_done() const { return step_; }
  /// Rollback (every world parked at one boundary, nothing in flight for
  /// it): the process goes on from `world`, rebuilt at scene step boundary
  /// `scene_step`, forgetting everything of later steps.
  void rewind(TerritoryWorld& world, std::int64_t scene_step);
  const CommitHorizon* horizon() const { return safety_.horizon; }

  struct Advance {
    bool progressed = false;  // some stage ran
    bool done = false;        // the target is reached
  };
  /// Takes every queued message, then runs stages until a message is missing
  /// or the target is reached. Never blocks.
  Advance advance();
  /// A message received by a blocking receive.
  void deliver(Message message);
  /// What the world waits for, for deadlock reports.
  std::string waiting_for() const;

  void add_blocked_ns(std::int64_t ns) { blocked_ns_ += ns; }
  /// Pool scheduling: when the world parked (set before parking).
  std::int64_t parked_at_ns = 0;

  WorldMetrics metrics() const;

 private:
  enum class Phase { Predict, AwaitGhosts, AwaitGlue, Merging, AwaitMigrants, Publish };
  using Key = std::tuple<int, std::int64_t, WorldId>;  // (kind, step, from)

  // Speculation (world_speculation.cpp).
  bool speculating() const { return safety_.anticipation > 0; }
  bool place_bets(MessageKind kind);
  bool within_anticipation();
  void record_used(const Key& key, const Message& m);
  bool compare_with_used(Message& m);
  void take_notice(WorldId from, std::int64_t step);
  void roll_back(std::int64_t step);
  std::int64_t checkpoint_at_or_before(std::int64_t step) const;
  void restore(std::int64_t step, std::int64_t changed_step, bool keep_old_run);
  void try_rejoin();
  void arm_replay();
  void drop_old_run();
  void recycle(WorldSnapshot&& state);
  void catch_up();
  void report_mark();
  void trim_below(std::int64_t gvt);
  // A neighbour's message this run used, kept while its step is above GVT.
  struct Used {
    std::uint64_t digest = 0;        // of the message's bytes, once unconfirmed
    bool confirmed = true;           // false: a bet not yet met, or void (re-send awaited)
    bool bet = false;                // assumed empty before it arrived
    std::optional<Message> message;  // for a re-run after this world rolls back
  };
  using UsedKey = std::tuple<std::int64_t, int, WorldId>;  // (step, kind, from)
  std::map<UsedKey, Used> used_;
  void await_resend(std::int64_t step, Used& u);
  std::map<std::int64_t, int> unconfirmed_;                 // step -> unconfirmed uses
  std::set<Key> bets_in_inbox_;
  std::set<Key> lost_bets_;                                 // never bet on these again
  std::map<WorldId, std::pair<std::int64_t, bool>> newest_ghosts_;  // per neighbour: step, not empty
  std::set<std::int64_t> merge_steps_;                      // steps with merge messages sent or used
  std::map<WorldId, std::uint64_t> notices_sent_;
  std::map<std::int64_t, WorldStepReport> reports_;         // validation: reported once committed
  std::map<std::int64_t, std::vector<Message>> sent_log_;   // Ghosts, Migrants, empty Glue sent, by step
  std::map<std::int64_t, LocalIslands> island_log_;         // islands solved in place, by step (propagate only)
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
  std::optional<OldRun> old_run_;
  // The step a rollback interrupted after its islands were solved: what it
  // had solved, for the re-run of that step to replay (arm_replay).
  struct PartialStep {
    std::int64_t step = -1;
    bool integrated = false;  // state taken after integrate(), else right after the solve
    LocalIslands islands;
    WorldSnapshot state;
  };
  std::optional<PartialStep> partial_step_;
  std::int64_t restored_to_ = -1;                           // the step the newest restore went back to
  std::uint64_t steps_rejoined_ = 0;                        // steps taken back from old runs, not re-run
  std::uint32_t seen_epoch_ = 0;                            // of the rollback board
  std::int64_t reported_through_ = -1;                      // validation: steps reported
  int checkpoint_every_ = 1;                                // speculation: keep a state every so many steps
  std::int64_t rerun_until_ = 0;                            // steps below it are re-runs

  bool run_phase();
  bool have_all(MessageKind kind, const std::vector<WorldId>& from) const;
  template <class Batch>
  std::vector<std::pair<WorldId, Batch>> take_all(MessageKind kind, const std::vector<WorldId>& from);
  void send(WorldId to, Message message);
  void flush_merger();
  void close_island(const std::vector<const Fragment*>& island);
  void take_gather(BodyId island, std::vector<Fragment> fragments);
  void gathered(BodyId island);
  void take_result(IslandResult result);
  void end_step();
  void check_watchdog();
  void apply_inputs();
  bool may_start();
  bool try_publish();
  void published(bool kept);
  void entry_published(std::int64_t scene_step, bool kept);
  TransformEntry<btScalar> entry_of(std::int64_t scene_step, const std::vector<BodyState>& states) const;
  void report_committed();

  TerritoryWorld* world_;  // replaced by rewind()
  Transport& transport_;
  const WorldGraph& graph_;
  Validator* validator_;
  std::function<void(std::int64_t)> progress_;
  int substeps_;
  bool solve_everywhere_;
  std::vector<WorldId> neighbours_;
  Safety safety_;
  std::map<std::int64_t, WorldSnapshot> kept_states_;  // by internal step
  std::vector<WorldSnapshot> spare_states_;             // speculation: freed kept states, reused

  Phase phase_ = Phase::Predict;
  std::int64_t step_ = 0;    // internal step in progress (= steps done)
  std::int64_t target_ = 0;
  Output output_;
  std::optional<TransformEntry<btScalar>> pending_;  // Publish: the entry waiting for room
  std::deque<TransformEntry<btScalar>> backlog_;  // Publish: entries of steps a rejoin took back, first
  bool publish_current_ = false;       // Publish: the entry of the step just ended is due
  std::int64_t next_publish_ = 0;      // scene steps below it are published (a re-run skips them)
  std::int64_t last_published_ = 0;    // speculation: newest scene step published
  std::int64_t committed_reported_ = 0;  // speculation: newest scene step reported to the RunControl
  std::int64_t room_wait_since_ns_ = 0;               // Publish: when it first found the buffer full
  std::map<Key, Message> inbox_;
  std::map<std::int64_t, std::vector<Message>> fragments_;  // Fragments and Results, by step
  IslandMerger merger_;
  // Border islands complete here, by smallest body id, until their result
  // is kept and passed on.
  struct Island {
    WorldId root = kNoWorld;
    WorldId parent = kNoWorld;
    std::vector<WorldId> children;
    std::vector<Fragment> data;     // fragments with data of this subtree
    std::size_t gathers_missing = 0;
  };
  std::map<BodyId, Island> islands_;
  std::map<BodyId, std::vector<Fragment>> early_gathers_;  // for islands not complete here yet

  // Metrics.
  WorldMetrics sums_;
  std::int64_t blocked_ns_ = 0;
  std::int64_t room_blocked_ns_ = 0;
  std::uint64_t entries_published_ = 0;
  std::uint64_t entries_dropped_ = 0;
  std::int64_t cpu_ns_ = 0;
  std::int64_t step_cpu_ns_ = 0;  // current step so far
  std::int64_t step_cpu_max_ns_ = 0;
  std::vector<std::int64_t> step_cpu_history_ns_;  // CPU time of every finished internal step
  std::uint64_t bets_ = 0, bets_lost_ = 0, rollbacks_ = 0, steps_rolled_back_ = 0, bodies_resolved_ = 0;
  std::uint64_t bodies_replayed_ = 0;
  std::int64_t rollback_cpu_ns_ = 0;    // restores and re-run steps
  std::int64_t restore_ns_in_step_ = 0;  // restores counted in step_cpu_ns_ so far
  std::vector<std::int32_t> lead_;
  std::size_t kept_max_ = 0;
};

}  // namespace soda
