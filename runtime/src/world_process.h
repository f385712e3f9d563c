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
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <tuple>
#include <vector>

#include "island_merge.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/transport.h"
#include "validator.h"

namespace soda {

class PartitionedWorld::Process {
 public:
  Process(TerritoryWorld& world, Transport& transport, const WorldGraph& graph, Validator* validator,
          std::function<void(std::int64_t)> progress, int substeps, bool solve_everywhere);

  /// Run until `internal_steps` steps are done.
  void set_target(std::int64_t internal_steps) { target_ = internal_steps; }

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
  enum class Phase { Predict, AwaitGhosts, AwaitGlue, Merging, AwaitMigrants };
  using Key = std::tuple<int, std::int64_t, WorldId>;  // (kind, step, from)

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

  TerritoryWorld& world_;
  Transport& transport_;
  const WorldGraph& graph_;
  Validator* validator_;
  std::function<void(std::int64_t)> progress_;
  int substeps_;
  bool solve_everywhere_;
  std::vector<WorldId> neighbours_;

  Phase phase_ = Phase::Predict;
  std::int64_t step_ = 0;    // internal step in progress (= steps done)
  std::int64_t target_ = 0;
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
  std::int64_t cpu_ns_ = 0;
  std::int64_t step_cpu_ns_ = 0;  // current step so far
  std::int64_t step_cpu_max_ns_ = 0;
  std::vector<std::int64_t> step_cpu_history_ns_;  // CPU time of every finished internal step
};

}  // namespace soda
