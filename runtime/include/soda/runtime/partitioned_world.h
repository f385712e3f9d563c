// runtime/ — the exact partitioned runtime: one scene simulated by K worlds,
// one per territory of a territory map, that talk only to their neighbours
// through messages; the result is bit-identical to one CanonicalWorld on the
// whole scene (same state_hash), for every K and every partition. Protocol:
// docs/partitioned-step.md. A world waits for its neighbours' messages of
// step t (never for anyone else), or bets on them (anticipation, docs/rollback.md).
//
//   soda::Scene scene = soda::make_scene("falling-cubes", {300, 1});
//   soda::TerritoryMap map = soda::make_partition("kmeans", scene, 4, {});
//   soda::PartitionedWorld world(scene, map, {.schedule = soda::Schedule::ThreadPerWorld});
//   world.step(300);
//   std::uint64_t h = world.state_hash();   // == CanonicalWorld(scene) after 300 steps
//
// Thread safety: a PartitionedWorld is driven by one thread at a time; step()
// runs the worlds on its own threads (per Schedule) and returns when every
// world has finished; the readers may be called between steps.
#pragma once

#include <atomic>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/loadbalance/policy.h"
#include "soda/runtime/balance_log.h"
#include "soda/runtime/message_traffic.h"
#include "soda/runtime/runtime_options.h"
#include "soda/runtime/schedule.h"
#include "soda/runtime/stage.h"
#include "soda/runtime/world_graph.h"
#include "soda/runtime/world_metrics.h"
#include "soda/scene/input_file.h"
#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/territory_world.h"
#include "soda/worlds/watchdog.h"

namespace soda {

namespace detail {
struct TestingHooks;  // internal (runtime/src/driver/testing_hooks.h)
}
class InputQueue;  // internal (runtime/src/step/input_queue.h)
class ProcessGroup;  // soda/runtime/process_group.h

struct PartitionedOptions {
  Schedule schedule = Schedule::Sequential;
  int threads = 0;         // Pool only: worker threads (>= 1)
  bool serialise = true;   // every message through bytes (message_codec.h); false: values
  /// The knobs every way of running a scene shares (runtime_options.h):
  /// speculation, parking, idle territories, reach, the solver pool, the
  /// watchdog, validation, pinning, load balancing.
  RuntimeOptions runtime = {};
  using Rollback = RuntimeOptions::Rollback;
  /// SyncTest (as GGPO's): after every scene step t, restore every world
  /// from the whole scene's state at step t - sync_test (kept in memory),
  /// re-run those steps and require the bodies' and the contacts' state at
  /// t to be bit-identical, else throw std::logic_error naming the step. A
  /// check of restore and of determinism; costs sync_test extra steps per
  /// step. 0: off.
  int sync_test = 0;
  /// Called by world 0's thread after each of its scene steps (its step count).
  std::function<void(std::int64_t)> progress = {};
  /// Each world keeps its state at every step boundary from the commit
  /// horizon to its clock (what a rollback restores; a snapshot per step).
  /// Implied by the watchdog's Heal response.
  bool keep_states = false;
  /// Internal: the knobs only tests set (an injected fault, fuzzing, the
  /// solve-everywhere protocol variant, replay verification); set through
  /// runtime/src/driver/testing_hooks.h. Leave empty.
  std::shared_ptr<const detail::TestingHooks> testing = {};
  /// A policy to use instead of make_balance_policy(runtime.balance)
  /// (tests, experiments); runtime.balance.period still sets the balance
  /// steps. Called from step()'s thread only; give one PartitionedWorld its
  /// own.
  std::shared_ptr<BalancePolicy> balance_policy = {};
  /// User inputs known before the run (scene/input_file.h, docs/inputs.md):
  /// each applied at its scene step boundary (after step `step`, before
  /// step + 1; every step >= the step the world starts at) by the world
  /// that owns the body (or a new body's home cell), in order of step and
  /// then of this list (`sequence` is ignored). The result equals a
  /// Simulation given the same inputs in the same order (the embedding
  /// API's hash) for every K, every policy, with speculation (the inputs are
  /// known ahead: a re-run step applies them again), SyncTest and heal.
  /// Checked as the Simulation's input calls check them: a bad input throws
  /// std::invalid_argument from the constructor naming it (its index,
  /// describe()) and what is wrong. Validation follows the inputs.
  std::vector<UserInput> inputs = {};
  /// Ranks (process_group.h; docs/mpi.md): this process steps only the
  /// worlds group->rank_of() gives its rank, and messages to other ranks'
  /// worlds go through the group. Every rank builds the same world from the
  /// same scene, map and options. Refused (std::invalid_argument) with
  /// the watchdog's Heal (docs/mpi.md). Under
  /// a group, step() and the whole-scene readers (body_states, state_hash,
  /// sleeping_count, body_count, metrics, snapshot) are collective: every
  /// rank calls them in the same order; rank 0 gets the whole scene's
  /// answer, the others their own worlds' (snapshot(): every rank gets the
  /// whole scene's state; the worlds' parts are gathered to every rank).
  /// Each rank keeps only its share of a scene (docs/mpi.md).
  /// Null: every world in this process.
  std::shared_ptr<ProcessGroup> group = {};
};

/// Thrown when the validation mode finds a broken invariant; the message names
/// the step, the bodies or pairs and the worlds.
class ValidationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class PartitionedWorld {
 public:
  /// One TerritoryWorld per world of `map`. Throws PartitionError (see
  /// territory_world.h) or std::invalid_argument for bad options. Over the
  /// ranks of a process group (options.group) each rank's worlds are built
  /// from its share of the scene (scene_share.h): the worlds it does not
  /// step hold no dynamic body.
  PartitionedWorld(const Scene& scene, TerritoryMap map, PartitionedOptions options = {});
  /// The same, taking the scene, which is freed once the worlds are built
  /// (they hold their own copies of what they need). Over ranks the rest of
  /// the scene is freed as soon as the rank's share is taken, before any
  /// world is built, so that a rank's peak memory is the whole scene's
  /// description or its share of the built worlds, whichever is larger
  /// (docs/mpi.md, "What a rank holds").
  PartitionedWorld(Scene&& scene, TerritoryMap map, PartitionedOptions options = {});
  /// From the whole scene's state at a step boundary (snapshot() of a
  /// PartitionedWorld with any map, or CanonicalWorld::snapshot()): steps
  /// exactly as the run the snapshot was taken from; steps_done() starts at
  /// state.steps_done.
  PartitionedWorld(const WorldSnapshot& state, TerritoryMap map, PartitionedOptions options = {});
  ~PartitionedWorld();
  PartitionedWorld(const PartitionedWorld&) = delete;
  PartitionedWorld& operator=(const PartitionedWorld&) = delete;

  /// Runs `n` scene steps (n * settings.substeps internal steps), as n calls
  /// of CanonicalWorld::step. Rethrows the first error of any world
  /// (PartitionError, ValidationError, MessageFormatError) after stopping all.
  void step(int n = 1);
  /// Scene steps done.
  std::int64_t steps_done() const { return steps_done_; }
  /// The whole scene's state now, between step() calls (every world at the
  /// same boundary): every body, statics included, by id, and the contact
  /// state of every pair, by (id0, id1) — the format of
  /// CanonicalWorld::snapshot(). Throws std::logic_error if two worlds own
  /// one body or hold different copies of one pair's contact state.
  WorldSnapshot snapshot() const;

  /// Raw states of every body, statics included, sorted by id.
  std::vector<BodyState> body_states() const;
  /// soda::state_hash(body_states()): equal to CanonicalWorld::state_hash().
  std::uint64_t state_hash() const;
  std::size_t sleeping_count() const;
  std::size_t body_count() const;

  int world_count() const;
  /// A world a cession kept (load balancing) holds a copy of an older map,
  /// equal to map() within the world's reach: use map() for the map in force.
  const TerritoryWorld& world(WorldId id) const;
  const WorldGraph& graph() const;
  std::vector<WorldMetrics> metrics() const;
  /// Messages and bytes through the transport so far.
  std::uint64_t messages_sent() const;
  std::uint64_t bytes_sent() const;
  /// Successful self-heals so far (watchdog response Heal), and the scene
  /// steps they re-simulated with substeps, in order.
  int heals() const { return static_cast<int>(healed_steps_.size()); }
  const std::vector<std::int64_t>& healed_steps() const { return healed_steps_; }
  /// SyncTest rollbacks done (each checked bit-identical).
  std::uint64_t sync_rollbacks() const { return sync_rollbacks_; }

  /// The territory map in force now (reach included: map_with_reach).
  const TerritoryMap& map() const;
  /// Why `body` cannot be added by input (its halo could reach worlds that
  /// are not neighbours: reach_refusal); "" if it can.
  std::string add_refusal(const Body& body) const;
  /// One record per balance step so far, in order (PartitionedOptions::
  /// balance; empty under policy "none"). Valid until the next step().
  const std::vector<BalanceRecord>& balance_log() const { return balance_log_; }
  /// What every world measured in every scene step step() ran, in step
  /// order (the first entry is the first step after construction). Steps
  /// re-run (SyncTest, heal) add to their entry. Valid until the next step().
  const std::vector<StepLoads>& step_loads() const { return step_loads_; }

  /// Runtime-internal, not for users: the worlds' processes, mailboxes and
  /// shared speculation state, through which the runtime's own drivers (the
  /// scheduler, a Simulation's engine) run them. An incomplete type outside
  /// runtime/src (partitioned_internals.h). Replaced by a restore (heal,
  /// SyncTest). Between steps only.
  struct Internals;
  Internals& internals() { return *in_; }

 private:
  class Process;
  // scene: needed by validation only (may be null without it).
  std::vector<std::unique_ptr<TerritoryWorld>> retire();
  void build(const Scene* scene, const TerritoryMap& map,
             const std::function<std::unique_ptr<TerritoryWorld>(WorldId)>& make_world);
  void restore(WorldSnapshot state);
  void init_from_scene(const Scene& scene, TerritoryMap map, Scene* owned);
  void init_inputs(const Scene& scene);
  TerritoryMap map_for_run(const Scene& scene, const TerritoryMap& map);
  void run_to(std::int64_t scene_step);
  // Over the ranks of options_.group (partitioned_ranks.cpp).
  bool steps_world(WorldId w) const;
  void check_group_options() const;
  void run_on_ranks(std::int64_t internal_target);
  std::vector<BodyState> gathered_states() const;
  std::size_t gathered_count(bool sleeping) const;
  WorldSnapshot gathered_snapshot() const;
  std::vector<WorldMetrics> gathered_metrics(std::vector<WorldMetrics> local) const;
  void sync_test_step();
  void restore_before(const WatchdogError& error);
  void resimulate_with_substeps();
  // Load balancing (balance_step.cpp).
  void init_balance();
  std::int64_t next_balance_step() const;
  bool balance_due() const;
  void balance();
  const std::vector<std::int32_t>& cell_triangles_for(const WorldSnapshot& state, const TerritoryMap& map);
  void collect_step_loads();
  void rebuild(const WorldSnapshot& state, const TerritoryMap& map);
  std::int64_t cede(const WorldSnapshot& state, const TerritoryMap& map);
  int rebuild_threads() const;

  PartitionedOptions options_;
  int substeps_ = 1;       // of the worlds now (a heal re-simulates a step with more)
  int base_substeps_ = 1;  // the scene's
  std::int64_t steps_done_ = 0;
  double reach_speed_ = 0;  // the run's (map_for_run)
  SceneSettings settings_;  // the scene's
  std::unique_ptr<Internals> in_;  // worlds, processes, transport, horizon, board
  std::shared_ptr<std::atomic<bool>> fault_fired_;
  std::shared_ptr<class FuzzRandom> fuzz_;
  int heal_attempts_ = 0;
  std::vector<WorldMetrics> carried_;  // counts of processes replaced by restores, per world
  std::deque<WorldSnapshot> sync_states_;  // SyncTest: the last sync_test + 1 boundaries
  std::uint64_t sync_rollbacks_ = 0;
  std::int64_t heal_at_ = 0;  // > 0: this scene step is re-simulated with substeps next
  std::vector<std::int64_t> healed_steps_;
  std::shared_ptr<BalancePolicy> policy_;  // null: no balance steps (policy "none")
  std::int64_t balanced_through_ = 0;      // the last balance step done (or the first step)
  std::vector<BalanceRecord> balance_log_;
  // Triangles within each box cell's reach (balance_step.cpp), for these
  // statics, box and grid.
  struct CellTriangles {
    std::vector<BodyId> statics;
    CellBox box;
    double cell_size = 0;
    Vec3 origin = Vec3::Zero();
    std::vector<std::int32_t> counts;  // empty: no level geometry
  };
  std::optional<CellTriangles> cell_triangles_;
  std::vector<StepLoads> step_loads_;
  std::int64_t first_step_ = 0;            // scene step step_loads_ starts after
  std::unique_ptr<InputQueue> inputs_;     // options_.inputs, checked and ordered; null: none
};

}  // namespace soda
