#include "driver/rank_record.h"

#include <algorithm>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "driver/partitioned_internals.h"
#include "driver/run_inputs.h"
#include "embedding/input_ledger.h"
#include "execution/plain_bytes.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/replay/replay_writer.h"
#include "soda/runtime/checkpoint.h"
#include "soda/runtime/process_group.h"
#include "soda/runtime/scene_reader.h"
#include "soda/runtime/simulation.h"
#include "soda/runtime/view_adapter.h"
#include "soda/scene/scene.h"

namespace soda {
namespace {

// One owned body as a rank sends it: the world that owns it and its state.
struct OwnedState {
  std::int32_t world = 0;
  BodyState state;
};
static_assert(std::is_trivially_copyable_v<OwnedState>);

std::vector<std::uint8_t> owned_here(const PartitionedWorld& world, ProcessGroup& group) {
  std::vector<std::uint8_t> out;
  const int k = world.world_count();
  for (WorldId w = 0; w < k; ++w) {
    if (group.rank_of(w, k) != group.rank()) continue;
    for (const BodyState& b : world.world(w).owned_states())
      put_plain(out, OwnedState{static_cast<std::int32_t>(w), b});
  }
  return out;
}

// The frame of `step` from every rank's part (rank 0), busy time per world
// since the previous frame from the worlds' CPU counters.
SceneFrame gathered_frame(const std::vector<std::vector<std::uint8_t>>& parts, std::int64_t step, double dt,
                          const std::vector<WorldMetrics>& metrics, std::vector<double>& cpu_before) {
  std::vector<OwnedState> all;
  for (const std::vector<std::uint8_t>& part : parts)
    for (std::size_t at = 0; at < part.size();)
      all.push_back(take_plain<OwnedState>(part, at, "--record over ranks: a rank's poses"));
  std::sort(all.begin(), all.end(), [](const OwnedState& a, const OwnedState& b) { return a.state.id < b.state.id; });
  SceneFrame f;
  f.step = step;
  f.time = static_cast<double>(step) * dt;
  f.poses.reserve(all.size());
  f.owners.reserve(all.size());
  for (std::size_t i = 0; i < all.size(); ++i) {
    if (i > 0 && all[i].state.id == all[i - 1].state.id)
      throw std::logic_error("--record over ranks: step " + std::to_string(step) + ": body " +
                             std::to_string(all[i].state.id) + " owned by worlds " + std::to_string(all[i - 1].world) +
                             " and " + std::to_string(all[i].world));
    f.poses.push_back(body_pose(all[i].state));
    f.owners.push_back(all[i].world);
  }
  if (step > 0) {
    f.busy_seconds.resize(metrics.size());
    for (std::size_t w = 0; w < metrics.size(); ++w) f.busy_seconds[w] = metrics[w].cpu_seconds - cpu_before[w];
  }
  cpu_before.resize(metrics.size());
  for (std::size_t w = 0; w < metrics.size(); ++w) cpu_before[w] = metrics[w].cpu_seconds;
  return f;
}

}  // namespace

void record_on_ranks(PartitionedWorld& world, const replay::ViewHeader* header, const TerritoryMap& map,
                     const RunConfig& config, RunResult& r) {
  ProcessGroup& group = *config.group;
  const bool writes = group.rank() == 0;
  if (writes != (header != nullptr))
    throw std::logic_error("record_on_ranks: rank 0, and only rank 0, passes the view header");
  const std::int64_t cpu0 = thread_cpu_ns();
  std::optional<replay::ReplayWriter> out;
  if (writes) {
    out.emplace(config.record_path, *header,
                replay::ReplayWriterOptions{config.record_keyframe_every, config.record_compression_level});
    describe_added_bodies(*out, config);
  }
  std::vector<double> cpu_before;
  for (std::int64_t k = 0; k <= config.steps; ++k) {
    if (k > 0) world.step(1);
    const std::vector<WorldMetrics> metrics = world.metrics();  // collective
    const std::vector<std::vector<std::uint8_t>> parts = group.gather(owned_here(world, group));
    const std::uint64_t hash = k == config.steps ? world.state_hash() : 0;  // collective
    if (!writes) continue;
    replay::ViewFrame v = view_frame(gathered_frame(parts, k, header->dt, metrics, cpu_before), *header,
                                     k == 0 ? &map : nullptr);
    if (k == config.steps) v.state_hash = hash;
    out->append(v);
  }
  if (!writes) return;
  out->close();
  r.record_frames = out->frames();
  r.record_bytes = out->bytes();
  r.record_cpu_seconds = static_cast<double>(thread_cpu_ns() - cpu0) * 1e-9;
}

void checkpoint_on_ranks(PartitionedWorld& world, const std::vector<UserInput>& inputs, const RunConfig& config,
                         RunResult& r) {
  ProcessGroup& group = *config.group;
  const std::int64_t first = config.resume ? config.resume->state.steps_done : 0;
  world.step(static_cast<int>(config.checkpoint_at - first));
  SimulationSnapshot at;
  at.state = world.snapshot();  // collective; every rank gets it
  // The inputs still to come as a Simulation queues them (by step, then as
  // given), and the ids retired before the step as its ledger keeps them.
  InputLedger ledger(Scene{});
  if (config.resume) {
    for (BodyId id : config.resume->retired_ids) ledger.retire(id);
    for (JointId id : config.resume->retired_joint_ids) ledger.retire_joint(id);
  }
  std::vector<UserInput> ordered = inputs;
  std::stable_sort(ordered.begin(), ordered.end(),
                   [](const UserInput& a, const UserInput& b) { return a.step < b.step; });
  for (const UserInput& in : ordered) {
    ledger.record(in);
    if (in.step >= config.checkpoint_at) at.inputs.push_back(in);
  }
  at.retired_ids = ledger.removed_before(config.checkpoint_at);
  at.retired_joint_ids = ledger.joints_removed_before(config.checkpoint_at);
  std::string failed;
  if (group.rank() == 0) {
    try {
      r.checkpoint_bytes = write_checkpoint(at, config.checkpoint_path);
    } catch (const CheckpointError& e) {
      failed = e.what();
    }
  }
  const std::vector<std::uint8_t> mine(failed.begin(), failed.end());
  for (const std::vector<std::uint8_t>& bytes : group.all_gather(mine))
    if (!bytes.empty()) throw CheckpointError(std::string(bytes.begin(), bytes.end()));
  r.checkpoint_step = at.state.steps_done;
  world.step(static_cast<int>(config.steps - config.checkpoint_at));
}

// --validate's bodies and contact pairs. On threads from a snapshot, which
// also throws if two worlds own one body; over ranks (a snapshot is refused
// where a rank holds a part of a mesh) the gathered count and every world's
// held pairs, summed over the ranks (every step's census checks the rest).
std::pair<std::size_t, std::size_t> census_counts(const PartitionedWorld& world, const RunConfig& config) {
  if (!config.group) {
    const WorldSnapshot s = world.snapshot();
    return {s.bodies.size(), s.manifolds.size()};
  }
  std::int64_t mine = 0;  // the pairs this rank's worlds hold (one holder a pair: the census checks it)
  for (WorldId w = 0; w < world.world_count(); ++w)
    if (config.group->rank_of(w, world.world_count()) == config.group->rank())
      mine += static_cast<std::int64_t>(world.world(w).held_contact_pairs().size());
  const std::int64_t pairs = summed_over_ranks(*config.group, {mine}).front();
  return {world.body_count(), static_cast<std::size_t>(pairs)};
}

}  // namespace soda
