// Internal: one world's side of the partitioned step — the step as a state
// machine over the TerritoryWorld's stages (soda/runtime/stage.h), waiting
// only for its neighbours' messages of the step. advance() runs as far as
// the messages at hand allow and never blocks, so the same machine runs
// under the round-robin driver, on a thread of its own (blocking on its
// mailbox between advances) or as a task of a pool (parked between
// advances). One step, top to bottom (run_phase() in world_process.cpp):
//
//   Predict        predict; exchange_ghosts: send Ghosts(t) to every neighbour
//   AwaitGhosts    <- Ghosts(t) from every neighbour; exchange_ghosts;
//                  collide; build_islands; glue: send Glue(t) to every
//                  neighbour that sent ghosts
//   AwaitGlue      <- Glue(t) from every neighbour ghosts were sent to;
//                  glue: border fragments; merge starts
//   Merging        merge <- Fragments(t) (headers) until every own island is
//                  complete; then the island's data climbs its tree
//                  (Gather(t), each world once its children's arrived) to
//                  the root (owner of its smallest body), which solves it;
//                  Results(t) descend the tree, each world keeping its part.
//                  Then integrate; migrate: send Migrants(t) to every
//                  neighbour
//   AwaitMigrants  <- Migrants(t) from every neighbour; migrate: absorb;
//                  step t done
//   Publish        (Simulation only, after each scene step) the owned bodies'
//                  poses to the world's transform buffer; waits while it is
//                  full (advance() returns, waiting_for_room() is true)
//
// How the step treats time is a component of its own, a Speculation
// (speculation.h): Lockstep, or Anticipation with Safety::anticipation > 0
// (docs/rollback.md). The step calls it through its hooks — on delivery,
// for a bet when a neighbour's Ghosts or Migrants are missing, before
// predict, for each message used or sent, after each step — and applies the
// Verdict each hook returns (apply()): messages in and out of the inbox, a
// restart in a rebuilt world (WorldStep::begin_again), notices to send.
// Each stage's CPU time, waits and counts go to a StageClock
// (WorldMetrics::stages).
//
// Under PartitionedWorld::step the world runs up to a fixed target; under a
// Simulation (attach()) it asks the RunControl before beginning each step.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "step/kept_states.h"
#include "step/process_options.h"
#include "speculation/speculation.h"
#include "step/stage_clock.h"
#include "step/validator.h"
#include "step/world_step.h"

namespace soda {

class PartitionedWorld::Process {
 public:
  using Safety = ProcessSafety;
  using Output = ProcessOutput;
  Process(TerritoryWorld& world, Transport& transport, const WorldGraph& graph, Validator* validator,
          std::function<void(std::int64_t)> progress, int substeps, bool solve_everywhere, Safety safety);

  /// Safety.keep_states: this world's part of the scene's state at scene step
  /// boundary `scene_step`, if still kept (kept from GVT to the world's clock).
  const WorldSnapshot* kept_state(std::int64_t scene_step) const;

  /// Run until `internal_steps` steps are done.
  void set_target(std::int64_t internal_steps) { target_ = internal_steps; }

  /// Before the first advance().
  void attach(Output output) { output_ = std::move(output); }
  /// True when the world stopped because its transform buffer is full (the
  /// Publish stage): it goes on once a reader frees an entry, or the buffer
  /// is stopped (the entry is then dropped).
  bool waiting_for_room() const { return s_.phase == StepPhase::Publish; }
  /// Publish stage on a thread of the world's own: waits for room (blocking
  /// in TransformBuffer::publish), publishes or drops the entry.
  void publish_blocking();
  /// Internal steps done.
  std::int64_t steps_done() const { return s_.step; }
  /// Rollback (every world parked at one boundary, nothing in flight for
  /// it): the process goes on from `world`, rebuilt at scene step boundary
  /// `scene_step`, forgetting everything of later steps.
  void rewind(TerritoryWorld& world, std::int64_t scene_step);
  /// Rewinds taken (messages.h: every message it sends carries the count).
  std::uint32_t rewinds() const { return rewinds_; }
  const CommitHorizon* horizon() const { return safety_.horizon; }

  struct Advance {
    bool progressed = false;  // some stage ran
    bool done = false;        // the target is reached
  };
  /// Takes every queued message, then runs stages until a message is missing
  /// or the target is reached. Never blocks.
  Advance advance();
  /// A message received by a blocking receive, delivered now.
  void deliver(Message message);
  /// The same, delivered by the next advance() before the messages it takes
  /// (in this order): inside its receive stage, so no clock is read for it
  /// alone (stage_clock.h; an idle step's cost, docs/skip.md).
  void hold(Message message) { held_.push_back(std::move(message)); }
  /// What the world waits for, for deadlock reports.
  std::string waiting_for() const;

  /// Wall time the world's thread waited for it (a blocking receive, a
  /// park): counted in the stage the world waits in.
  void add_blocked_ns(std::int64_t ns);
  /// Tasks of another world's solve this world's thread ran while it
  /// waited (Scheduler: SolverPool guests); the time inside their jobs
  /// (a running thread's: its CPU time) counts in Stage::Solve.
  void add_guest_work(std::int64_t tasks, std::int64_t busy_ns);

  /// Any thread: waits for the world's thread to leave advance() and the
  /// calls above (activity()), so a world parked at its limit that still
  /// takes a message (speculating: until the horizon reaches it) is read
  /// between two of them.
  WorldMetrics metrics() const;
  /// Held by the world's thread (the scheduler's task) around advance(),
  /// hold(), add_blocked_ns() and add_guest_work(); never while blocked.
  std::mutex& activity() const { return activity_; }

  /// One finished internal step, as PartitionedWorld::step_loads() needs it.
  struct StepRecord {
    std::int64_t step = 0;     // internal steps done when it finished
    std::int64_t cpu_ns = 0;   // the step's CPU time (restores before it included)
    std::int64_t wait_ns = 0;  // blocked since the previous step finished
    std::int32_t bodies = 0;   // owned at its end
    std::int32_t lead = 0;     // speculation: clock - commit horizon at its end; else 0
    std::int32_t islands = 0;  // local islands + merged islands solved here (its last substep)
  };
  /// The records of the steps finished since the last call, in the order
  /// they finished (a re-run step again). None under a Simulation (nobody
  /// takes them). Between advances only.
  std::vector<StepRecord> take_step_log() { return std::exchange(step_log_, {}); }

 private:
  bool run_phase();
  // The stages (soda/runtime/stage.h), each in its StageClock scope.
  void predict();
  void send_ghosts();
  void exchange_ghosts();
  void collide();
  void build_islands();
  void send_glue();
  void glue();
  bool merge();
  void integrate();
  void send_migrants();
  void migrate();
  bool publish();

  bool have_all(MessageKind kind, const std::vector<WorldId>& from) const;
  bool have_or_bet(MessageKind kind);
  std::vector<WorldId> glue_senders() const;
  template <class Batch>
  std::vector<std::pair<WorldId, Batch>> take_all(MessageKind kind, const std::vector<WorldId>& from);
  void send(WorldId to, Message message);
  // The merge (world_merge.cpp).
  void flush_merger();
  void close_island(const std::vector<const Fragment*>& island);
  void take_gather(BodyId island, std::vector<Fragment> fragments);
  void gathered(BodyId island);
  void take_result(std::shared_ptr<const IslandResult> result);
  void end_step();
  // What speculation decided (speculation.h).
  void apply(Verdict v);
  void edit_inbox(InboxEdit& e);
  void resend(Message m);
  void check_watchdog();
  bool take_rewind();
  void apply_inputs();
  // Idle territories (docs/skip.md).
  bool fault_due() const;
  bool woken();
  void skip_idle_step();
  bool may_start();
  // Publishing (world_publish.cpp).
  bool try_publish();
  void published(bool kept);
  void entry_published(std::int64_t scene_step, bool kept);
  // Costs.
  void step_costs_done();
  Stage waiting_stage() const;

  Transport& transport_;
  const WorldGraph& graph_;
  Validator* validator_;
  std::function<void(std::int64_t)> progress_;
  int substeps_;
  bool solve_everywhere_;
  std::vector<WorldId> neighbours_;
  Safety safety_;
  Output output_;
  std::int64_t target_ = 0;
  WorldStep s_;                            // the step in progress
  KeptStates kept_;                        // keep_states, speculation
  std::unique_ptr<Speculation> spec_;      // Anticipation (anticipation > 0) or Lockstep

  // Metrics.
  mutable std::mutex activity_;  // see activity()
  WorldMetrics sums_;
  StageClock clock_;                       // per-stage costs; its published() totals are the metrics
  std::vector<Message> held_;              // hold(): for the next advance()
  std::uint32_t rewinds_ = 0;              // rewind() calls: stamped on every message sent
  std::int64_t step_start_cpu_ns_ = 0;     // clock_ total at the last step's end
  std::int64_t entry_cpu_mark_ns_ = 0;     // clock_ total when the last entry was made (busy_seconds)
  std::int64_t step_start_rollback_ns_ = 0;  // ... its rollback stage's
  std::int64_t step_cpu_max_ns_ = 0;
  std::vector<std::int64_t> step_cpu_history_ns_;  // CPU time of every finished internal step
  std::int64_t blocked_ns_ = 0;
  std::uint64_t guest_tasks_ = 0;  // add_guest_work
  std::int64_t step_start_blocked_ns_ = 0;  // blocked_ns_ at the last step's end
  std::vector<StepRecord> step_log_;         // since the last take_step_log()
  std::int64_t room_blocked_ns_ = 0;
  std::uint64_t entries_published_ = 0;
  std::uint64_t entries_dropped_ = 0;
};

}  // namespace soda
