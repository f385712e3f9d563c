// Internal: what runs a Simulation — the PartitionedWorld's world processes
// on the long-lived threads of a Scheduler (scheduler.h: the three schedules)
// gated by the RunControl, publishing to the buffers of the SimulationCore;
// user inputs, and rollbacks for inputs at past steps.
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

#include "embedding/input_ledger.h"
#include "step/input_queue.h"
#include "driver/partitioned_internals.h"
#include "execution/scheduler.h"
#include "embedding/simulation_core.h"
#include "soda/runtime/simulation.h"

namespace soda {

class SimulationEngine {
 public:
  SimulationEngine(const Scene& scene, TerritoryMap map, SimulationConfig config);
  SimulationEngine(const SimulationSnapshot& snapshot, TerritoryMap map, SimulationConfig config);
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
  /// Simulation::snapshot, once wait_idle returned.
  SimulationSnapshot snapshot() const;
  std::uint64_t rollbacks() const;
  /// Simulation::input_log.
  std::vector<UserInput> input_log() const;

  std::shared_ptr<SimulationCore> core;
  std::unique_ptr<PartitionedWorld> world;
  Schedule schedule = Schedule::ThreadPerWorld;
  int threads = 1;

 private:
  void set_up(const Scene& scene, const PartitionedOptions& options, std::unique_ptr<PartitionedWorld> world,
              std::int64_t start);
  void launch_locked();
  void fail(WorldId world, std::exception_ptr error);
  PartitionedWorld::Internals& parts() { return world->internals(); }
  void rollback_locked(std::int64_t scene_step);
  void rewind_world(WorldId w, const WorldSnapshot& state);
  /// SimulationConfig::on_contacts: its thread, once the engine is built.
  void start_contact_callback();

  SimulationConfig config_;
  int substeps_ = 1;
  mutable std::mutex lifecycle_;
  bool launched_ = false;
  bool stopped_ = false;
  std::unique_ptr<Scheduler> scheduler_;  // from the first start
  // Input (under lifecycle_).
  InputLedger ledger_;
  InputQueue inputs_;
  std::uint64_t next_sequence_ = 0;
  std::uint64_t rollbacks_ = 0;
  std::vector<UserInput> given_;  // every input the calls gave and the run took, in call order
  // on_contacts: the thread that calls it, joined by stop() (under join_).
  std::thread contact_thread_;
  std::mutex join_;
};

}  // namespace soda
