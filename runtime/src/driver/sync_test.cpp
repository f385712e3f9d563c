// SyncTest (docs/rollback.md): one step, then back sync_test steps (or as
// far as kept) and forward again; the state must come out bit-identical.
// Over ranks (docs/mpi.md) each rank keeps and restores only its own
// worlds' parts — a world rebuilt from its own part plus the statics, as
// speculation's restores do — compares them as a rejoin does (same_bits),
// and the ranks agree on the verdict with one all-gather.
#include <algorithm>
#include <cstring>
#include <string>
#include <vector>

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

}  // namespace soda
