// PartitionedWorld's load balancing (docs/loadbalance.md, "How a cession is
// applied"): the balance steps, the LoadView a policy decides on, the moves
// checked and applied by rebuilding the worlds a cession changes for the new
// map from the whole scene's state at the balance step (the others keep
// their worlds), and the per-step loads.
//
// Why a rebuild is exact: a TerritoryWorld built from a whole-scene snapshot
// steps exactly as the worlds the snapshot was taken from, for any map
// (tests/runtime/snapshot_restore_test.cpp) — the bodies of a ceded cell
// arrive at their new owner with their raw state, and every pair's contact
// state goes to its key body's new owner. Every world stands at the balance
// step (step() drains to it), so no rollback can reach below it. A world
// kept beside rebuilt ones is what a rollback of one world is
// (changed_worlds says why its step is unchanged).
#include <algorithm>
#include <atomic>
#include <exception>
#include <functional>
#include <limits>
#include <optional>
#include <thread>
#include <map>
#include <set>
#include <span>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "driver/partitioned_internals.h"
#include "execution/plain_bytes.h"
#include "soda/grid/cell_triangles.h"
#include "soda/loadbalance/load_monitor.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/process_group.h"
#include "soda/worlds/world_snapshot.h"

namespace soda {
namespace {

constexpr std::int32_t kSleeping = 2;  // Bullet's ISLAND_SLEEPING: the one state TerritoryWorld counts asleep

// Policy contract point 2 (policy.h): a broken one is a bug of the policy.
void check_moves(const std::vector<CellMove>& moves, const TerritoryMap& map, const char* policy,
                 std::int64_t step) {
  std::set<std::size_t> seen;
  for (std::size_t i = 0; i < moves.size(); ++i) {
    const CellMove& m = moves[i];
    std::ostringstream text;
    text << "balance policy '" << policy << "' at step " << step << ": move " << i << " (cell (" << m.cell.x << ", "
         << m.cell.y << ", " << m.cell.z << ") from world " << m.from << " to world " << m.to << ") ";
    const std::string what = text.str();
    if (!map.box().contains(m.cell)) throw std::logic_error(what + "names a cell outside the map's box");
    if (m.to < 0 || m.to >= map.world_count() || m.to == m.from)
      throw std::logic_error(what + "names no other world of the " + std::to_string(map.world_count()));
    if (map.owner(m.cell) != m.from)
      throw std::logic_error(what + "but world " + std::to_string(map.owner(m.cell)) + " owns the cell");
    if (!seen.insert(map.box().index(m.cell)).second) throw std::logic_error(what + "moves the cell twice");
  }
}

// CellLoad of every box cell holding a dynamic body, canonical order (box
// index order is lexicographic x, y, z). A pair counts at its key body's
// cell: the dynamic body of a static pair, else the lower id.
// triangles: per box cell, the triangles within its reach (empty: none
// counted, BalanceOptions::triangle_cost off or no level geometry).
std::vector<CellLoad> cell_loads(const WorldSnapshot& state, const TerritoryMap& map,
                                 const std::vector<std::int32_t>& triangles) {
  const CellBox& box = map.box();
  std::vector<std::int64_t> index(state.bodies.size(), -1);  // box index of each body's home cell; -1: static
  std::map<std::int64_t, CellLoad> cells;
  for (std::size_t i = 0; i < state.bodies.size(); ++i) {
    const BodySnapshot& b = state.bodies[i];
    if (b.description.is_static) continue;
    const btScalar* o = b.state.origin;
    const CellCoord c = box.clamp(map.grid().cell_of(Vec3(double(o[0]), double(o[1]), double(o[2]))));
    index[i] = static_cast<std::int64_t>(box.index(c));
    CellLoad& l = cells[index[i]];
    l.cell = c;
    l.owner = map.owner(c);
    if (!triangles.empty()) l.triangles = triangles[static_cast<std::size_t>(index[i])];
    ++l.bodies;
    if (b.state.activation_state != kSleeping) ++l.awake_bodies;
  }
  auto position = [&](BodyId id) {
    auto it = std::lower_bound(state.bodies.begin(), state.bodies.end(), id,
                               [](const BodySnapshot& b, BodyId v) { return b.description.id < v; });
    return static_cast<std::size_t>(it - state.bodies.begin());
  };
  for (const ManifoldState& m : state.manifolds) {
    const std::size_t i0 = position(m.id0), i1 = position(m.id1);
    if (i0 >= index.size() || i1 >= index.size()) continue;
    const std::int64_t key = index[i0] >= 0 ? index[i0] : index[i1];
    if (key >= 0) ++cells[key].contact_pairs;
  }
  std::vector<CellLoad> out;
  out.reserve(cells.size());
  for (auto& [i, l] : cells) out.push_back(l);
  return out;
}

// The worlds a cession changes: the owners (before it) of every box cell
// within the map's reach of a moved cell, and every move's recipient. Any
// other world has no cell within reach of a moved cell, so none of its
// bodies' halos overlaps one (a halo beyond the reach is a PartitionError),
// it holds no copy of a moved body and no pair of one, and every owner it
// looks up (ghost targets, migration, rule H, its neighbours, its interior)
// is the same in both maps: it steps on exactly as it would have, in its
// Bullet world, with its map (docs/loadbalance.md, "How a cession is
// applied").
std::vector<bool> changed_worlds(const TerritoryMap& before, const TerritoryMap& after) {
  std::vector<bool> changed(static_cast<std::size_t>(before.world_count()), false);
  const CellBox& box = before.box();
  const int r = before.reach();
  const std::span<const WorldId> was = before.owners(), now = after.owners();
  for (std::size_t i = 0; i < was.size(); ++i) {
    if (was[i] == now[i]) continue;
    changed[static_cast<std::size_t>(now[i])] = true;
    const CellCoord m = box.cell_at(i);
    for (int dx = -r; dx <= r; ++dx)
      for (int dy = -r; dy <= r; ++dy)
        for (int dz = -r; dz <= r; ++dz) {
          const CellCoord c{m.x + dx, m.y + dy, m.z + dz};
          if (box.contains(c)) changed[static_cast<std::size_t>(before.owner(c))] = true;
        }
  }
  return changed;
}

// f(w) for every world, on `threads` threads (the caller's among them);
// rethrows the first error. The stepping threads are idle meanwhile.
void for_each_world(int k, int threads, const std::function<void(WorldId)>& f) {
  std::atomic<int> next{0};
  std::vector<std::exception_ptr> errors(static_cast<std::size_t>(k));
  auto work = [&] {
    for (int w; (w = next++) < k;) try {
        f(w);
      } catch (...) {
        errors[static_cast<std::size_t>(w)] = std::current_exception();
      }
  };
  std::vector<std::thread> helpers;
  for (int i = 1; i < std::min(threads, k); ++i) helpers.emplace_back(work);
  work();
  for (std::thread& t : helpers) t.join();
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace

BalanceTotals balance_totals(const std::vector<BalanceRecord>& log) {
  BalanceTotals t;
  for (const BalanceRecord& r : log) {
    ++t.balance_steps;
    t.cells_moved += r.cells_moved;
    t.bodies_moved += r.bodies_moved;
    t.gather_cpu_seconds += r.gather_cpu_seconds;
    t.decide_cpu_seconds += r.decide_cpu_seconds;
    t.apply_cpu_seconds += r.apply_cpu_seconds;
    t.wall_seconds += r.wall_seconds;
  }
  return t;
}

void PartitionedWorld::init_balance() {
  if (options_.balance_policy) {
    BalanceOptions checked = options_.runtime.balance;  // the knobs are checked even when the policy is given
    checked.policy = "none";
    make_balance_policy(checked);
    policy_ = options_.balance_policy;
  } else {
    std::unique_ptr<BalancePolicy> made = make_balance_policy(options_.runtime.balance);
    if (options_.runtime.balance.policy != "none") policy_ = std::move(made);
  }
  balanced_through_ = first_step_ = steps_done_;
}

const TerritoryMap& PartitionedWorld::map() const { return in_->map; }

std::int64_t PartitionedWorld::next_balance_step() const {
  if (!policy_) return std::numeric_limits<std::int64_t>::max();
  const std::int64_t p = options_.runtime.balance.period;
  return (steps_done_ / p + 1) * p;
}

bool PartitionedWorld::balance_due() const {
  return policy_ && steps_done_ > balanced_through_ && steps_done_ % options_.runtime.balance.period == 0;
}

// The triangles within each box cell's reach, counted once for the map's
// grid and box and the scene's statics (again only if the statics change:
// cessions keep the grid and the box).
const std::vector<std::int32_t>& PartitionedWorld::cell_triangles_for(const WorldSnapshot& state,
                                                                      const TerritoryMap& map) {
  static const std::vector<std::int32_t> none;
  if (!options_.runtime.balance.triangle_cost) return none;
  std::vector<Body> statics;
  for (const BodySnapshot& b : state.bodies)
    if (b.description.is_static) statics.push_back(b.description);
  std::vector<BodyId> ids;
  for (const Body& b : statics) ids.push_back(b.id);
  if (!cell_triangles_.has_value() || cell_triangles_->statics != ids || !(cell_triangles_->box == map.box()) ||
      cell_triangles_->cell_size != map.grid().cell_size() || cell_triangles_->origin != map.grid().origin()) {
    CellTriangles t{ids, map.box(), map.grid().cell_size(), map.grid().origin(), {}};
    if (has_level_geometry(statics)) t.counts = cell_triangles(statics, map.grid(), map.box());
    cell_triangles_ = std::move(t);
  }
  return cell_triangles_->counts;
}

// Every world stands at steps_done_ (step() ran them to it).
void PartitionedWorld::balance() {
  BalanceRecord rec;
  rec.step = steps_done_;
  const std::int64_t wall0 = wall_ns(), cpu0 = thread_cpu_ns();
  const WorldSnapshot state = snapshot();  // also throws if two worlds own one body
  const TerritoryMap map = this->map();    // O(1) copy: the rebuild replaces the worlds
  const int k = map.world_count();
  LoadView view;
  view.step = steps_done_;
  view.map = &map;
  view.cells = cell_loads(state, map, cell_triangles_for(state, map));
  view.worlds.resize(static_cast<std::size_t>(k));
  std::vector<std::int64_t> pairs(static_cast<std::size_t>(k), 0);
  for (WorldId w = 0; w < k; ++w)
    if (steps_world(w))
      pairs[static_cast<std::size_t>(w)] =
          static_cast<std::int64_t>(in_->worlds[static_cast<std::size_t>(w)]->held_contact_pairs().size());
  if (options_.group) pairs = summed_over_ranks(*options_.group, std::move(pairs));  // every rank decides alike
  for (WorldId w = 0; w < k; ++w) {
    WorldLoad& l = view.worlds[static_cast<std::size_t>(w)];
    l.world = w;
    l.cells = map.cell_count(w);
    l.contact_pairs = pairs[static_cast<std::size_t>(w)];
  }
  for (const CellLoad& c : view.cells) {
    WorldLoad& l = view.worlds[static_cast<std::size_t>(c.owner)];
    l.bodies += c.bodies;
    l.awake_bodies += c.awake_bodies;
    l.body_triangles += static_cast<std::int64_t>(c.awake_bodies) * c.triangles;
  }
  // The period's steps: means per internal step.
  std::vector<double> lead_sum(static_cast<std::size_t>(k), 0.0);
  std::int64_t scene_steps = 0;
  for (const StepLoads& s : step_loads_) {
    if (s.step <= balanced_through_ || s.step > steps_done_) continue;
    ++scene_steps;
    for (WorldId w = 0; w < k; ++w) {
      const WorldStepLoad& x = s.worlds[static_cast<std::size_t>(w)];
      WorldLoad& l = view.worlds[static_cast<std::size_t>(w)];
      l.busy += x.busy_seconds;
      l.wait += x.wait_seconds;
      lead_sum[static_cast<std::size_t>(w)] += x.lead;
      l.islands = x.islands;
    }
  }
  for (WorldId w = 0; w < k; ++w) {
    WorldLoad& l = view.worlds[static_cast<std::size_t>(w)];
    l.steps = scene_steps * substeps_;
    if (l.steps == 0) continue;
    l.busy /= static_cast<double>(l.steps);
    l.wait /= static_cast<double>(l.steps);
    l.lead = lead_sum[static_cast<std::size_t>(w)] / static_cast<double>(scene_steps);
  }
  const std::int64_t cpu1 = thread_cpu_ns();
  std::int64_t helper_ns = 0;  // CPU time of the rebuild's helper threads
  rec.moves = policy_->decide(view);
  if (const LoadMonitor* monitor = policy_->monitor()) rec.prediction = monitor->last_prediction();
  const std::int64_t cpu2 = thread_cpu_ns();
  check_moves(rec.moves, map, policy_->name(), steps_done_);
  rec.cells_moved = static_cast<std::int64_t>(rec.moves.size());
  for (auto* per_world : {&rec.cells_out, &rec.cells_in, &rec.bodies_out, &rec.bodies_in})
    per_world->assign(static_cast<std::size_t>(k), 0);
  if (!rec.moves.empty()) {
    std::vector<std::pair<CellCoord, WorldId>> changes;
    std::map<std::size_t, const CellMove*> moved;  // by box index
    for (const CellMove& m : rec.moves) {
      changes.emplace_back(m.cell, m.to);
      moved.emplace(map.box().index(m.cell), &m);
      ++rec.cells_out[static_cast<std::size_t>(m.from)];
      ++rec.cells_in[static_cast<std::size_t>(m.to)];
    }
    for (const CellLoad& c : view.cells) {
      const auto it = moved.find(map.box().index(c.cell));
      if (it == moved.end()) continue;
      rec.bodies_moved += c.bodies;
      rec.bodies_out[static_cast<std::size_t>(it->second->from)] += c.bodies;
      rec.bodies_in[static_cast<std::size_t>(it->second->to)] += c.bodies;
    }
    // The reach is the scene's and the cell size's, not the owners': the
    // map keeps it (reassigned), as map_with_reach would give it again.
    helper_ns = cede(state, map.reassigned(changes));
  }
  const std::int64_t cpu3 = thread_cpu_ns() + helper_ns;
  rec.gather_cpu_seconds = static_cast<double>(cpu1 - cpu0) * 1e-9;
  rec.decide_cpu_seconds = static_cast<double>(cpu2 - cpu1) * 1e-9;
  rec.apply_cpu_seconds = static_cast<double>(cpu3 - cpu2) * 1e-9;
  rec.wall_seconds = static_cast<double>(wall_ns() - wall0) * 1e-9;
  for (WorldId w = 0; w < k; ++w) rec.cells_owned.push_back(this->map().cell_count(w));
  balanced_through_ = steps_done_;
  balance_log_.push_back(std::move(rec));
}

// After every run of the worlds: their finished steps' records, by scene
// step. Over ranks every rank's, gathered to every rank (collective), so
// that every rank's policy decides on the same loads.
void PartitionedWorld::collect_step_loads() {
  const int k = world_count();
  std::vector<std::pair<WorldId, Process::StepRecord>> records;
  for (WorldId w = 0; w < k; ++w)
    if (steps_world(w))
      for (const Process::StepRecord& r : in_->process(w).take_step_log()) records.emplace_back(w, r);
  if (options_.group) {
    static_assert(std::is_trivially_copyable_v<Process::StepRecord>);
    std::vector<std::uint8_t> mine;
    for (const auto& [w, r] : records) put_plain(mine, static_cast<std::int32_t>(w)), put_plain(mine, r);
    records.clear();
    for (const std::vector<std::uint8_t>& part : options_.group->all_gather(mine))
      for (std::size_t at = 0; at < part.size();) {
        const auto w = static_cast<WorldId>(take_plain<std::int32_t>(part, at, "a rank's step records"));
        records.emplace_back(w, take_plain<Process::StepRecord>(part, at, "a rank's step records"));
      }
  }
  for (const auto& [w, r] : records) {
    const std::int64_t scene_step = (r.step - 1) / substeps_ + 1;
    if (scene_step <= first_step_) continue;
    const std::size_t i = static_cast<std::size_t>(scene_step - first_step_ - 1);
    while (step_loads_.size() <= i) {
      StepLoads s;
      s.step = first_step_ + static_cast<std::int64_t>(step_loads_.size()) + 1;
      s.worlds.resize(static_cast<std::size_t>(k));
      step_loads_.push_back(std::move(s));
    }
    WorldStepLoad& l = step_loads_[i].worlds[static_cast<std::size_t>(w)];
    l.busy_seconds += static_cast<double>(r.cpu_ns) * 1e-9;
    l.wait_seconds += static_cast<double>(r.wait_ns) * 1e-9;
    l.bodies = r.bodies;
    l.cells = static_cast<std::int32_t>(map().cell_count(w));
    l.lead = r.lead;
    l.islands = r.islands;
  }
}

// The worlds (and their processes, mailboxes, horizon) rebuilt from the
// whole scene's state for `map`; the replaced processes' counts are carried.
void PartitionedWorld::rebuild(const WorldSnapshot& state, const TerritoryMap& map) {
  substeps_ = state.settings.substeps;
  steps_done_ = state.steps_done;
  std::optional<Scene> scene;
  if (options_.runtime.validate) scene = scene_of(state);
  build(scene ? &*scene : nullptr, map, [&](WorldId w) { return std::make_unique<TerritoryWorld>(state, w, map); });
}

// The cession: the worlds it changes (changed_worlds) rebuilt for the new
// map from the whole scene's state, on rebuild_threads() threads (each new
// world shares its predecessor's Bullet pools), their old ones destroyed
// there too; every other world is kept as it stands, Bullet world, pairs and
// contact state. Concurrent building and destruction of TerritoryWorlds is
// what speculation's rollbacks already do on the worlds' own threads, and a
// kept world beside rebuilt ones is what a rollback of one world is. Every
// world gets a new process (mailbox, horizon, board) for the new neighbour
// sets. Returns the helper threads' CPU time, ns.
std::int64_t PartitionedWorld::cede(const WorldSnapshot& state, const TerritoryMap& map) {
  const std::vector<bool> changed = changed_worlds(this->map(), map);
  const int threads = rebuild_threads();
  std::vector<WorldId> rebuilt;
  for (WorldId w = 0; w < world_count(); ++w)
    if (changed[static_cast<std::size_t>(w)]) rebuilt.push_back(w);
  const int n = static_cast<int>(rebuilt.size());
  std::atomic<std::int64_t> helper_ns{0};
  const std::thread::id me = std::this_thread::get_id();
  auto timed = [&](const std::function<void(std::size_t)>& f) {
    return [&, f](WorldId i) {
      const std::int64_t c0 = thread_cpu_ns();
      f(static_cast<std::size_t>(rebuilt[static_cast<std::size_t>(i)]));
      if (std::this_thread::get_id() != me) helper_ns += thread_cpu_ns() - c0;
    };
  };
  // Over ranks another rank's world is built empty here, as from a share:
  // the statics and kinematic bodies only (it is never stepped here).
  std::optional<WorldSnapshot> empty;
  if (options_.group) {
    empty.emplace(state);
    std::erase_if(empty->bodies, [](const BodySnapshot& b) { return !b.description.is_static; });
    empty->manifolds.clear();
    empty->joints.clear();
  }
  std::vector<std::unique_ptr<TerritoryWorld>> fresh(static_cast<std::size_t>(world_count()));
  for_each_world(n, threads, timed([&](std::size_t w) {
                   const WorldSnapshot& from = steps_world(static_cast<WorldId>(w)) ? state : *empty;
                   fresh[w] = std::make_unique<TerritoryWorld>(from, static_cast<WorldId>(w), map, -1,
                                                               in_->worlds[w].get());
                 }));
  std::vector<std::unique_ptr<TerritoryWorld>> old = retire();
  for_each_world(n, threads, timed([&](std::size_t w) { old[w].reset(); }));
  for (std::size_t w = 0; w < old.size(); ++w)
    if (!changed[w]) fresh[w] = std::move(old[w]);
  std::optional<Scene> scene;
  if (options_.runtime.validate) scene = scene_of(state);
  build(scene ? &*scene : nullptr, map, [&](WorldId w) { return std::move(fresh[static_cast<std::size_t>(w)]); });
  return helper_ns.load();
}

// As many threads as step the worlds (the caller's alone when sequential),
// at most one per CPU: more only add switches to pure CPU work.
int PartitionedWorld::rebuild_threads() const {
  const int cpus = std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  switch (options_.schedule) {
    case Schedule::Sequential: return 1;
    case Schedule::ThreadPerWorld: return std::min(world_count(), cpus);
    case Schedule::Pool: return std::min(options_.threads, cpus);
  }
  return 1;
}

}  // namespace soda
