// Internal: what runs a Simulation — the PartitionedWorld's world processes
// driven by long-lived threads under a RunControl, publishing to the
// buffers of the SimulationCore. Three schedules, as PartitionedWorld's:
//
//   ThreadPerWorld  world i's thread: advance; parked at the limit -> wait
//                   for the limit to rise; buffer full -> wait in publish;
//                   missing a message -> block on its mailbox
//   Pool            T workers; a world runs until it must wait, then parks:
//                   on the transport (messages) or in `parked` (limit, room),
//                   re-queued by the transport's or the RunControl's hook
//   Sequential      one thread, worlds round-robin; when none can go on it
//                   waits for a wake-up (limit, room), or reports a deadlock
//
// A world never waits for room in a way that holds a thread other worlds
// need (docs/embedding.md, "Back-pressure").
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "input_queue.h"
#include "simulation_core.h"
#include "soda/runtime/simulation.h"
#include "world_process.h"

namespace soda {

class SimulationEngine {
 public:
  SimulationEngine(const Scene& scene, TerritoryMap map, SimulationConfig config);
  ~SimulationEngine();

  void start(std::int64_t internal_limit);
  bool advance_to(std::int64_t scene_step);
  void stop();
  bool stopped() const;
  int substeps() const { return substeps_; }
  /// Readouts: waits until they are safe (see Simulation).
  void wait_idle(const char* caller) const;
  /// Simulation's input calls (validated here; see simulation.h).
  void input(UserInput input);
  std::int64_t commit_horizon_step() const;
  std::uint64_t rollbacks() const;

  std::shared_ptr<SimulationCore> core;
  std::unique_ptr<PartitionedWorld> world;
  Schedule schedule = Schedule::ThreadPerWorld;
  int threads = 1;

 private:
  struct Pool;
  void launch_locked();
  void fail(WorldId world, std::exception_ptr error);
  void run_world(WorldId w);
  void run_sequential();
  void run_pool_worker(int index);
  PartitionedWorld::Process& process(WorldId w) { return *world->processes_[static_cast<std::size_t>(w)]; }
  void check_input_locked(const UserInput& input) const;
  void rollback_locked(std::int64_t scene_step);
  void rewind_world(WorldId w, const WorldSnapshot& state);

  SimulationConfig config_;
  int substeps_ = 1;
  mutable std::mutex lifecycle_;
  bool launched_ = false;
  bool stopped_ = false;
  std::vector<std::thread> threads_;
  std::shared_ptr<Pool> pool_;
  // Input (under lifecycle_).
  struct Life {
    bool is_static = false;
    std::int64_t added = 0;                // present from this boundary on
    std::int64_t removed = INT64_MAX;      // gone from this boundary on
    std::int64_t last_input = -1;          // newest step of an input naming it
  };
  std::map<BodyId, Life> lives_;
  SceneSettings settings_;
  InputQueue inputs_;
  std::uint64_t next_sequence_ = 0;
  std::uint64_t rollbacks_ = 0;
};

}  // namespace soda
