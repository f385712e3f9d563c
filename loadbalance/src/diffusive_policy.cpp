#include "diffusive_policy.h"

#include <algorithm>
#include <numeric>

#include "cession_planner.h"

namespace soda::detail {

DiffusivePolicy::DiffusivePolicy(const BalanceOptions& options) : options_(options), monitor_(options) {}

std::vector<CellMove> DiffusivePolicy::decide(const LoadView& view) {
  monitor_.update(view);
  const int k = static_cast<int>(view.worlds.size());
  if (view.map == nullptr || k < 2 || view.map->world_count() != k) return {};
  famine_periods_.resize(static_cast<std::size_t>(k), 0);
  if (!(monitor_.mean() > 0)) return {};
  const std::vector<LoadClass>& cls = monitor_.classes();
  const auto is = [&](WorldId w, LoadClass c) { return cls[static_cast<std::size_t>(w)] == c; };
  CessionPlanner plan(view, monitor_, options_);

  std::vector<WorldId> by_load(static_cast<std::size_t>(k));
  std::iota(by_load.begin(), by_load.end(), 0);
  std::stable_sort(by_load.begin(), by_load.end(),
                   [&](WorldId a, WorldId b) { return plan.load(a) > plan.load(b); });

  // Famine is "not having large enough a territory" (§3.3.5): a world
  // holding at least its share of the box's cells is idle because its part
  // of the scene is, not for want of territory (and the load may be coming:
  // moving it away would hand that space to one neighbour).
  const double share = static_cast<double>(view.map->box().count()) / k;
  const auto small = [&](WorldId w) { return static_cast<double>(view.map->cell_count(w)) < share; };
  // A desert: every neighbour of w is underloaded too, so no load can reach
  // w through them before they are loaded themselves — a load crossing
  // towards w is at least a world away. Such a world starves whatever its
  // share of cells, and relocates sooner (kDesertFaminePeriods).
  const auto desert = [&](WorldId w) {
    const std::vector<WorldId>& n = view.map->neighbours(w);
    return !n.empty() && std::all_of(n.begin(), n.end(), [&](WorldId v) { return is(v, LoadClass::Underloaded); });
  };
  std::vector<char> deserted(static_cast<std::size_t>(k), 0);
  for (WorldId w = 0; w < k; ++w) deserted[static_cast<std::size_t>(w)] = desert(w) ? 1 : 0;

  // 0. Famine (§3.3.5), before any cession so that the most loaded world
  //    still has its cells to spare: a world that starved for
  //    kFaminePeriods balance steps running (counted below) relocates next
  //    to the most loaded world; at most one relocation per balance step,
  //    the least loaded starving world first.
  const bool any_overloaded = std::any_of(cls.begin(), cls.end(), [](LoadClass c) { return c == LoadClass::Overloaded; });
  for (auto it = by_load.rbegin(); it != by_load.rend() && any_overloaded; ++it) {
    const WorldId u = *it;
    const int needed = deserted[static_cast<std::size_t>(u)] ? kDesertFaminePeriods : kFaminePeriods;
    if (famine_periods_[static_cast<std::size_t>(u)] < needed || !is(u, LoadClass::Underloaded)) continue;
    const WorldId h = by_load.front();  // the most loaded
    if (h == u || !is(h, LoadClass::Overloaded)) break;
    if (plan.relocate(u, h)) break;
  }

  // 1. Overloaded worlds give, most loaded first, to their recipients in
  //    priority order, until the excess over the mean is given.
  const auto give = [&](WorldId g, bool givers_too) {
    double want = plan.load(g) - plan.mean();
    bool gave = false;
    for (WorldId r : plan.recipients_of(g, givers_too)) {
      if (!(want > 0) || plan.given(g) >= plan.cap(g)) break;
      // An overloaded neighbour that has not given yet gives in its turn:
      // receiving now would stop it (rule d), and its own less loaded
      // neighbours would get nothing (hotspot on 8 worlds, step 10: world 1
      // gave to world 2, which then could not give to idle world 3). The
      // cascade gives to it once it has given on.
      if (!givers_too && is(r, LoadClass::Overloaded) && plan.role(r) == CessionPlanner::Role::None) continue;
      const double delta = std::min(want, 0.5 * (plan.load(g) - plan.load(r)));
      if (delta > 0) {
        const double given = plan.cede(g, r, delta);
        want -= given;
        gave = gave || given > 0;
      }
    }
    return gave;
  };
  for (WorldId g : by_load)
    if (is(g, LoadClass::Overloaded) && plan.role(g) != CessionPlanner::Role::Recipient) give(g, false);
  //    The cascade: an overloaded world whose neighbours were as loaded as
  //    itself gave nothing; once a neighbour has given on, it is less loaded
  //    and may receive (a giver receiving from the other side), so a load
  //    spread over several worlds moves one world further per pass rather
  //    than per balance step (hotspot on 8 worlds: the block covers 4 of
  //    them, and worlds 4-6 got load at steps 30, 50-60 and 80-100). Each
  //    world still gives at most once; rule c still holds for every cell.
  //    lb_replay (model times, seed 1): hotspot 400 / 8 worlds, period 10,
  //    1.432 -> 1.417; avalanche 400 / 4 worlds, 16 cells, 1.608 -> 1.429;
  //    drift 900 / 2 and hotspot 400 / 2 unchanged (two worlds: no cascade).
  for (bool more = true; more;) {
    more = false;
    for (WorldId g : by_load)
      if (is(g, LoadClass::Overloaded) && plan.role(g) == CessionPlanner::Role::None && give(g, true)) more = true;
  }
  // 2. Underloaded worlds ask, least loaded first: the most loaded neighbour
  //    above the mean (and not underloaded itself) gives.
  for (auto it = by_load.rbegin(); it != by_load.rend(); ++it) {
    const WorldId u = *it;
    if (!is(u, LoadClass::Underloaded) || plan.role(u) == CessionPlanner::Role::Giver) continue;
    WorldId best = kNoWorld;
    for (WorldId n : view.map->neighbours(u)) {
      if (plan.role(n) == CessionPlanner::Role::Recipient || is(n, LoadClass::Underloaded) ||
          !(plan.load(n) > plan.mean()) || plan.given(n) >= plan.cap(n) || !(plan.load(n) > plan.load(u)))
        continue;
      if (best == kNoWorld || plan.load(n) > plan.load(best)) best = n;
    }
    if (best == kNoWorld) continue;
    const double delta = std::min(plan.mean() - plan.load(u), 0.5 * (plan.load(best) - plan.load(u)));
    if (delta > 0) plan.cede(best, u, delta);
  }
  // 3. Famine counters: an underloaded world that obtained nothing from its
  //    neighbours in this balance step — none above the mean, or none with
  //    a cell it could give — while some world is overloaded starves.
  for (WorldId u = 0; u < k; ++u) {
    const bool starving = any_overloaded && is(u, LoadClass::Underloaded) &&
                          plan.role(u) == CessionPlanner::Role::None &&
                          (small(u) || deserted[static_cast<std::size_t>(u)]);
    int& periods = famine_periods_[static_cast<std::size_t>(u)];
    periods = starving ? periods + 1 : 0;
  }
  // 4. Empty cells go with the load they border (after the famine counters:
  //    tidying is no cession obtained) — in a balance step that moves cells
  //    anyway: a step of tidying alone would rebuild the worlds around it
  //    for a few empty cells (drift 900 on 2 worlds: 2 to 27 cells at 4 of
  //    its first 6 balance steps, each a rebuild of both worlds, 3-4 ms, and
  //    a first step after it 1.7 ms dearer).
  if (!plan.moves().empty()) plan.tidy();
  return plan.moves();
}

}  // namespace soda::detail
