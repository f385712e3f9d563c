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
  const int cap = options_.max_cells_per_move;

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

  // 0. Famine (§3.3.5), before any cession so that the most loaded world
  //    still has its cells to spare: a world that starved for
  //    kFaminePeriods balance steps running (counted below) relocates next
  //    to the most loaded world; at most one relocation per balance step,
  //    the least loaded starving world first.
  const bool any_overloaded = std::any_of(cls.begin(), cls.end(), [](LoadClass c) { return c == LoadClass::Overloaded; });
  for (auto it = by_load.rbegin(); it != by_load.rend() && any_overloaded; ++it) {
    const WorldId u = *it;
    if (famine_periods_[static_cast<std::size_t>(u)] < kFaminePeriods || !is(u, LoadClass::Underloaded)) continue;
    const WorldId h = by_load.front();  // the most loaded
    if (h == u || !is(h, LoadClass::Overloaded)) break;
    if (plan.relocate(u, h)) break;
  }

  // 1. Overloaded worlds give, most loaded first, to their recipients in
  //    priority order, until the excess over the mean is given.
  for (WorldId g : by_load) {
    if (!is(g, LoadClass::Overloaded) || plan.role(g) == CessionPlanner::Role::Recipient) continue;
    double want = plan.load(g) - plan.mean();
    for (WorldId r : plan.recipients_of(g)) {
      if (!(want > 0) || plan.given(g) >= cap) break;
      const double delta = std::min(want, 0.5 * (plan.load(g) - plan.load(r)));
      if (delta > 0) want -= plan.cede(g, r, delta);
    }
  }
  // 2. Underloaded worlds ask, least loaded first: the most loaded neighbour
  //    above the mean (and not underloaded itself) gives.
  for (auto it = by_load.rbegin(); it != by_load.rend(); ++it) {
    const WorldId u = *it;
    if (!is(u, LoadClass::Underloaded) || plan.role(u) == CessionPlanner::Role::Giver) continue;
    WorldId best = kNoWorld;
    for (WorldId n : view.map->neighbours(u)) {
      if (plan.role(n) == CessionPlanner::Role::Recipient || is(n, LoadClass::Underloaded) ||
          !(plan.load(n) > plan.mean()) || plan.given(n) >= cap || !(plan.load(n) > plan.load(u)))
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
                          plan.role(u) == CessionPlanner::Role::None && small(u);
    int& periods = famine_periods_[static_cast<std::size_t>(u)];
    periods = starving ? periods + 1 : 0;
  }
  // 4. Empty cells go with the load they border (after the famine counters:
  //    tidying is no cession obtained).
  plan.tidy();
  return plan.moves();
}

}  // namespace soda::detail
