// PartitionedWorld over the ranks of a ProcessGroup (process_group.h,
// docs/mpi.md): which options a run over ranks supports, the step with the
// group's communication loop on the caller's thread, and the whole-scene
// readouts gathered to rank 0 (the snapshot to every rank).
//
// Every rank builds every TerritoryWorld (the same map and options) from
// its share of the scene (scene_share.h), and steps only its own; the
// others hold no dynamic body and are never read. With speculation the group computes the commit horizon over
// the ranks and carries the rollback board's posts (docs/mpi.md).
#include <algorithm>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>

#include "driver/partitioned_internals.h"
#include "execution/plain_bytes.h"
#include "soda/runtime/process_group.h"
#include "soda/worlds/snapshot_parts.h"

namespace soda {

namespace {

static_assert(std::is_trivially_copyable_v<BodyState>);
static_assert(std::is_trivially_copyable_v<StageCosts>);

constexpr const char* kReadout = "PartitionedWorld: a rank's gathered readout";

template <class T>
void put(std::vector<std::uint8_t>& out, const T& v) {
  put_plain(out, v);
}

template <class T>
T take(const std::vector<std::uint8_t>& in, std::size_t& at) {
  return take_plain<T>(in, at, kReadout);
}

// A world's metrics as they travel to rank 0: every counter
// (for_each_counter) and the per-step means and maxima; the per-step series
// (cpu_step_ms, lead) and the traffic stay on the rank that measured them.
template <class M, class F>
void each_scalar(M& m, F&& f) {
  f(m.world), f(m.steps), f(m.stages), f(m.cpu_step_mean_ms), f(m.cpu_step_max_ms), f(m.lead_mean);
  for_each_counter(m, [&](const char*, auto& value, CounterFold) { f(value); });
}

void put_report(std::vector<std::uint8_t>& out, const WorldStepReport& r) {
  put(out, static_cast<std::int32_t>(r.world));
  put(out, r.step);
  put(out, static_cast<std::uint64_t>(r.owned.size()));
  for (BodyId id : r.owned) put(out, id);
  for (std::size_t n : {r.ghosts, r.statics, r.bullet_objects, r.parked}) put(out, static_cast<std::uint64_t>(n));
  put(out, static_cast<std::uint64_t>(r.held_pairs.size()));
  for (const auto& [a, b] : r.held_pairs) put(out, a), put(out, b);
}

WorldStepReport take_report(const std::vector<std::uint8_t>& in, std::size_t& at) {
  WorldStepReport r;
  r.world = take<std::int32_t>(in, at);
  r.step = take<std::int64_t>(in, at);
  const auto count = [&](std::size_t item) {
    const auto n = take<std::uint64_t>(in, at);
    if (n > (in.size() - at) / item) throw std::logic_error(std::string(kReadout) + " is truncated");
    return static_cast<std::size_t>(n);
  };
  r.owned.resize(count(sizeof(BodyId)));
  for (BodyId& id : r.owned) id = take<BodyId>(in, at);
  for (std::size_t* n : {&r.ghosts, &r.statics, &r.bullet_objects, &r.parked})
    *n = static_cast<std::size_t>(take<std::uint64_t>(in, at));
  r.held_pairs.resize(count(2 * sizeof(BodyId)));
  for (auto& [a, b] : r.held_pairs) a = take<BodyId>(in, at), b = take<BodyId>(in, at);
  return r;
}

}  // namespace

// Validation over ranks: each rank's worlds' reports, gathered to every
// rank, checked alike on every rank (validator.h). Collective.
void gather_validation(ProcessGroup& group, Validator& validator) {
  std::vector<std::uint8_t> mine;
  for (const WorldStepReport& r : validator.take_pending()) put_report(mine, r);
  std::vector<WorldStepReport> all;
  for (const std::vector<std::uint8_t>& bytes : group.all_gather(mine))
    for (std::size_t at = 0; at < bytes.size();) all.push_back(take_report(bytes, at));
  validator.check_gathered(std::move(all));
}

std::vector<std::int64_t> summed_over_ranks(ProcessGroup& group, std::vector<std::int64_t> mine) {
  std::vector<std::uint8_t> bytes;
  for (std::int64_t v : mine) put(bytes, v);
  std::fill(mine.begin(), mine.end(), 0);
  for (const std::vector<std::uint8_t>& part : group.all_gather(bytes)) {
    std::size_t at = 0;
    for (std::int64_t& v : mine) v += take<std::int64_t>(part, at);
  }
  return mine;
}

bool PartitionedWorld::steps_world(WorldId w) const {
  return !options_.group || options_.group->rank_of(w, world_count()) == options_.group->rank();
}

void PartitionedWorld::check_group_options() const {
  const auto refuse = [](const std::string& what) {
    throw std::invalid_argument("PartitionedWorld over ranks (MPI, docs/mpi.md): " + what +
                                " is not supported yet");
  };
  if (options_.runtime.watchdog.response == WatchdogResponse::Heal) refuse("the watchdog's heal");
}

// The scheduler's threads step this rank's worlds; the caller's thread (the
// one that initialised MPI) moves messages between ranks meanwhile.
void PartitionedWorld::run_on_ranks(std::int64_t internal_target) {
  ProcessGroup& group = *options_.group;
  if (options_.runtime.anticipation > 0) group.set_horizon_goal(internal_target);
  Scheduler::Options o;
  // Round-robin on one thread cannot tell a deadlock from a message still
  // on its way from another rank: one pool worker instead.
  o.schedule = options_.schedule == Schedule::Sequential ? Schedule::Pool : options_.schedule;
  o.threads = options_.schedule == Schedule::Sequential ? 1 : options_.threads;
  o.pin = options_.runtime.pin;
  o.guest_pool = in_->solver_pool.get();  // this rank's worlds share their solver pool, as on threads
  for (WorldId w = 0; w < world_count(); ++w) o.local.push_back(steps_world(w));
  Scheduler scheduler(std::move(o), in_->task_list(), *in_->transport, nullptr,
                      [&group](WorldId w, std::exception_ptr error) {
                        std::string what = "unknown error";
                        try {
                          std::rethrow_exception(error);
                        } catch (const std::exception& e) {
                          what = e.what();
                        } catch (...) {
                        }
                        group.report_failure("world " + std::to_string(w) + ": " + what);
                      });
  scheduler.launch();
  try {
    group.pump([&scheduler] { return scheduler.finished(); });
  } catch (...) {
    in_->transport->close();  // the worlds stop; the error is this rank's
    scheduler.join();
    throw;
  }
  if (!group.remote_failure().empty()) in_->transport->close();
  scheduler.join();
  const std::string remote = group.remote_failure();
  std::exception_ptr error = scheduler.error();
  if (error) {
    try {
      std::rethrow_exception(error);
    } catch (const TransportClosed&) {
      if (remote.empty()) throw;
    }
  }
  if (!remote.empty()) throw std::runtime_error(remote);
}

std::vector<BodyState> PartitionedWorld::gathered_states() const {
  std::vector<std::uint8_t> mine;
  for (WorldId w = 0; w < world_count(); ++w)
    if (steps_world(w))
      for (const BodyState& b : world(w).owned_states()) put(mine, b);
  const std::vector<std::vector<std::uint8_t>> all = options_.group->gather(mine);
  std::vector<BodyState> out = in_->worlds.front()->static_states();
  for (const std::vector<std::uint8_t>& part : all.empty() ? std::vector<std::vector<std::uint8_t>>{mine} : all) {
    if (part.size() % sizeof(BodyState)) throw std::logic_error("PartitionedWorld: a rank's body states are truncated");
    for (std::size_t at = 0; at < part.size();) out.push_back(take<BodyState>(part, at));
  }
  std::sort(out.begin(), out.end(), [](const BodyState& a, const BodyState& b) { return a.id < b.id; });
  return out;
}

// The whole scene's state on every rank: each rank's worlds' parts, as
// bytes (deserialize_part_snapshot: a part names ghosts and statics it does
// not hold), and the statics and kinematic bodies from the rank that steps
// world 0 (a world of another rank is never stepped here: its kinematic
// bodies stand where the scene put them), assembled as on threads.
WorldSnapshot PartitionedWorld::gathered_snapshot() const {
  enum Kind : std::uint8_t { kPart = 0, kStatics = 1, kCut = 2 };
  std::vector<std::uint8_t> mine;
  const auto put_bytes = [&mine](Kind kind, const WorldSnapshot& s) {
    const std::vector<std::uint8_t> bytes = serialize(s);
    put(mine, kind);
    put(mine, static_cast<std::uint64_t>(bytes.size()));
    mine.insert(mine.end(), bytes.begin(), bytes.end());
  };
  // A rank whose worlds hold a part of a mesh or heightfield (scene_share.h)
  // names it, and every rank refuses alike: no rank holds its whole.
  for (WorldId w = 0; w < world_count(); ++w) {
    if (!steps_world(w)) continue;
    for (const BodySnapshot& s : world(w).static_snapshots()) {
      const Shape& shape = s.description.shape;
      if ((shape.mesh && shape.mesh->cut) || (shape.heightfield && shape.heightfield->window.columns != 0)) {
        put(mine, kCut);
        put(mine, static_cast<std::uint64_t>(s.description.id));
        break;
      }
    }
    break;
  }
  for (WorldId w = 0; w < world_count(); ++w) {
    if (!steps_world(w)) continue;
    WorldSnapshot part = world(w).part_snapshot();
    put_bytes(kPart, part);
    if (w != 0) continue;
    part.bodies = world(0).static_snapshots();
    part.manifolds.clear();
    part.joints.clear();
    put_bytes(kStatics, part);
  }
  std::vector<WorldSnapshot> parts;
  std::optional<std::vector<BodySnapshot>> statics;
  for (const std::vector<std::uint8_t>& bytes : options_.group->all_gather(mine))
    for (std::size_t at = 0; at < bytes.size();) {
      const auto kind = take<Kind>(bytes, at);
      const auto n = take<std::uint64_t>(bytes, at);
      if (kind == kCut)
        throw std::runtime_error("PartitionedWorld::snapshot over MPI ranks: static body " + std::to_string(n) +
                                 " is a triangle mesh or heightfield that each rank holds only a part of (docs/mpi.md, "
                                 "\"What a rank holds\"), so no rank can write it whole");
      if (n > bytes.size() - at) throw std::logic_error("PartitionedWorld::snapshot: a rank's part is truncated");
      WorldSnapshot s = deserialize_part_snapshot(
          std::vector<std::uint8_t>(bytes.begin() + static_cast<std::ptrdiff_t>(at),
                                    bytes.begin() + static_cast<std::ptrdiff_t>(at + n)));
      at += n;
      if (kind == kStatics) statics = std::move(s.bodies);
      else parts.push_back(std::move(s));
    }
  if (!statics || parts.size() != static_cast<std::size_t>(world_count()))
    throw std::logic_error("PartitionedWorld::snapshot: the ranks sent " + std::to_string(parts.size()) +
                           " parts for " + std::to_string(world_count()) + " worlds");
  return Internals::assemble(steps_done_, std::move(parts), std::move(*statics));
}

std::size_t PartitionedWorld::gathered_count(bool sleeping) const {
  std::uint64_t n = 0;
  for (WorldId w = 0; w < world_count(); ++w)
    if (steps_world(w)) n += sleeping ? world(w).sleeping_count() : world(w).owned_count();
  std::vector<std::uint8_t> mine;
  put(mine, n);
  const std::vector<std::vector<std::uint8_t>> all = options_.group->gather(mine);
  if (all.empty()) return n;
  n = 0;
  for (const std::vector<std::uint8_t>& part : all) {
    std::size_t at = 0;
    n += take<std::uint64_t>(part, at);
  }
  return n;
}

// Each world's counters from the rank that stepped it.
std::vector<WorldMetrics> PartitionedWorld::gathered_metrics(std::vector<WorldMetrics> local) const {
  std::vector<std::uint8_t> mine;
  for (WorldMetrics& m : local)
    if (steps_world(m.world)) each_scalar(m, [&](const auto& v) { put(mine, v); });
  const std::vector<std::vector<std::uint8_t>> all = options_.group->gather(mine);
  for (const std::vector<std::uint8_t>& part : all)
    for (std::size_t at = 0; at < part.size();) {
      WorldMetrics m;
      each_scalar(m, [&](auto& v) { v = take<std::remove_reference_t<decltype(v)>>(part, at); });
      if (m.world < 0 || m.world >= world_count()) throw std::logic_error("PartitionedWorld: a gathered world id");
      if (!steps_world(m.world)) local[static_cast<std::size_t>(m.world)] = std::move(m);
    }
  return local;
}

}  // namespace soda
