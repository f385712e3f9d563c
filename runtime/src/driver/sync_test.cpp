// SyncTest (docs/rollback.md): one step, then back sync_test steps (or as
// far as kept) and forward again; the state must come out bit-identical.
// Over ranks (docs/mpi.md) each rank keeps and restores only its own
// worlds' parts — a world rebuilt from its own part plus the statics, as
// speculation's restores do — compares them as a rejoin does (same_bits),
// and the ranks agree on the verdict with one all-gather. Also the
// watchdog's heal, which restores a kept step and re-runs the bad one with
// more substeps.
#include <algorithm>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include <spdlog/spdlog.h>

#include "driver/partitioned_internals.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/runtime/process_group.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {

// One step, then back sync_test steps (or as far as kept) and forward again:
// the state must come out bit-identical.
void PartitionedWorld::sync_test_step() {
  if (options_.group) {
    // sync_states_ over ranks: world_count() entries per boundary, by world id
    // (this rank's worlds' parts; the others' hold only the step).
    const int k = world_count();
    const auto parts = [&] {
      std::vector<WorldSnapshot> out(static_cast<std::size_t>(k));
      for (WorldId w = 0; w < k; ++w) {
        if (steps_world(w)) out[static_cast<std::size_t>(w)] = world(w).part_snapshot();
        out[static_cast<std::size_t>(w)].steps_done = steps_done_;
      }
      return out;
    };
    if (sync_states_.empty())
      for (WorldSnapshot& p : parts()) sync_states_.push_back(std::move(p));
    run_to(steps_done_ + 1);
    std::vector<WorldSnapshot> now = parts();
    const std::int64_t t = steps_done_;
    const std::int64_t back = sync_states_.front().steps_done;
    // Rebuild every world at `back`: this rank's from its kept part plus the
    // statics, the others' (never stepped here) empty.
    const std::vector<BodySnapshot> statics = in_->worlds.front()->static_snapshots();
    std::vector<WorldSnapshot> wholes;
    for (WorldId w = 0; w < k; ++w) {
      WorldSnapshot whole = steps_world(w) ? sync_states_[static_cast<std::size_t>(w)] : world(w).part_snapshot();
      if (!steps_world(w)) whole.bodies.clear(), whole.manifolds.clear();
      whole.steps_done = back;
      whole.bodies.insert(whole.bodies.end(), statics.begin(), statics.end());
      std::sort(whole.bodies.begin(), whole.bodies.end(), [](const BodySnapshot& a, const BodySnapshot& b) {
        return a.description.id < b.description.id;
      });
      wholes.push_back(std::move(whole));
    }
    const TerritoryMap map = this->map();
    steps_done_ = back;
    build(nullptr, map, [&](WorldId w) {
      return std::make_unique<TerritoryWorld>(wholes[static_cast<std::size_t>(w)], w, map, back * substeps_);
    });
    run_to(t);
    ++sync_rollbacks_;
    const std::vector<WorldSnapshot> again = parts();
    std::string verdict;
    for (WorldId w = 0; w < k && verdict.empty(); ++w)
      if (steps_world(w) && !same_bits(now[static_cast<std::size_t>(w)], again[static_cast<std::size_t>(w)]))
        verdict = "rank " + std::to_string(options_.group->rank()) + ", world " + std::to_string(w);
    for (const std::vector<std::uint8_t>& v : options_.group->all_gather({verdict.begin(), verdict.end()}))
      if (!v.empty())
        throw std::logic_error("SyncTest: step " + std::to_string(t) + " re-run from step " + std::to_string(back) +
                               " is not bit-identical (first difference: " + std::string(v.begin(), v.end()) + ")");
    for (WorldSnapshot& p : now) sync_states_.push_back(std::move(p));
    while (static_cast<int>(sync_states_.size()) > options_.sync_test * k)
      for (int i = 0; i < k; ++i) sync_states_.pop_front();
    return;
  }
  if (sync_states_.empty()) sync_states_.push_back(snapshot());
  run_to(steps_done_ + 1);
  WorldSnapshot now = snapshot();
  const WorldSnapshot& back = sync_states_.front();
  const std::int64_t t = steps_done_;
  restore(back);
  run_to(t);
  ++sync_rollbacks_;
  const WorldSnapshot again = snapshot();
  if (serialize(again) != serialize(now)) {
    std::string first = "the contact state";
    for (std::size_t i = 0; i < std::min(now.bodies.size(), again.bodies.size()); ++i) {
      const BodyDynamicState& a = now.bodies[i].state;
      const BodyDynamicState& b = again.bodies[i].state;
      if (std::memcmp(a.origin, b.origin, sizeof a.origin) || std::memcmp(a.basis, b.basis, sizeof a.basis) ||
          std::memcmp(a.linear_velocity, b.linear_velocity, sizeof a.linear_velocity) ||
          std::memcmp(a.angular_velocity, b.angular_velocity, sizeof a.angular_velocity)) {
        first = "body " + std::to_string(now.bodies[i].description.id);
        break;
      }
    }
    throw std::logic_error("SyncTest: step " + std::to_string(t) + " re-run from step " +
                           std::to_string(back.steps_done) + " is not bit-identical (first difference: " + first +
                           ")");
  }
  sync_states_.push_back(std::move(now));
  while (static_cast<int>(sync_states_.size()) > options_.sync_test) sync_states_.pop_front();
}

// The step whose result the watchdog objects to. A non-finite state or an
// absurd speed comes out of the step that finds it. A penetration does not:
// a step's contact points are found from the positions the step before left
// (collision detection runs before the solve), so a penetration found at
// step t was made by step t - 1, and re-simulating t would find it again.
namespace {
std::int64_t heal_step(const WatchdogError& error) {
  for (const WatchdogFinding& f : error.findings())
    if (f.kind == WatchdogFinding::Kind::Penetration && error.step() > 1) return error.step() - 1;
  return error.step();
}
}  // namespace

// The worlds stopped wherever they were; the newest step whose state every
// world still keeps, before the step to heal, is where they start again
// (worlds keep one step below GVT for this: world_process.cpp). Right after
// a heal the worlds keep nothing before the healed step: a penetration it
// left is then healed at the step that found it.
void PartitionedWorld::restore_before(const WatchdogError& error) {
  std::int64_t bad = heal_step(error);
  std::int64_t r = bad - 1;
  std::optional<WorldSnapshot> whole = in_->kept_snapshot(r, base_substeps_);
  while (!whole && r > 0) whole = in_->kept_snapshot(--r, base_substeps_);
  if (!whole && bad < error.step()) {
    bad = error.step();
    r = bad - 1;
    whole = in_->kept_snapshot(r, base_substeps_);
  }
  if (!whole)
    throw WatchdogError(error.step(), error.world(), error.findings(), options_.runtime.watchdog.limits,
                        "self-heal found no step every world keeps");
  restore(std::move(*whole));
  sync_states_.clear();
  heal_at_ = bad;
  spdlog::warn("watchdog: {}; rolling back to step {} to re-simulate step {} with {} substeps", error.what(), r,
               heal_at_, options_.runtime.watchdog.heal_substeps);
}

// At the boundary before the bad step: that one step as heal_substeps
// substeps of every world, then the usual step size again.
void PartitionedWorld::resimulate_with_substeps() {
  WorldSnapshot at = snapshot();
  at.settings.substeps = base_substeps_ * options_.runtime.watchdog.heal_substeps;
  restore(std::move(at));
  run_to(steps_done_ + 1);
  WorldSnapshot after = snapshot();
  after.settings.substeps = base_substeps_;
  restore(std::move(after));
  healed_steps_.push_back(heal_at_);
  heal_at_ = 0;
}

}  // namespace soda
