#include "cession_planner.h"

#include <algorithm>
#include <cstdlib>
#include <tuple>

namespace soda::detail {

CessionPlanner::CessionPlanner(const LoadView& view, const LoadMonitor& monitor, const BalanceOptions& options)
    : view_(view), options_(options), grid_(*view.map) {
  const CellBox& box = grid_.box();
  const std::size_t k = view.worlds.size();
  cost_.assign(static_cast<std::size_t>(box.count()), 0.0);
  moved_.assign(cost_.size(), 0);
  for (const CellLoad& cell : view.cells) cost_[box.index(box.clamp(cell.cell))] += monitor.model().cell_cost(cell);
  load_ = monitor.estimated();
  load_.resize(k, 0.0);
  kappa_.assign(k, 1.0);
  for (std::size_t w = 0; w < k; ++w) {
    const double predicted = monitor.model().predict(view.worlds[w]);
    if (predicted > 0 && load_[w] > 0)
      kappa_[w] = std::clamp(load_[w] / predicted, 1.0 / kCalibrationLimit, kCalibrationLimit);
  }
  role_.assign(k, Role::None);
  given_.assign(k, 0);
  mean_ = monitor.mean();
  cap_.assign(k, options.max_cells_per_move);
  for (std::size_t w = 0; w < k && mean_ > 0; ++w) {
    const double factor = std::clamp((load_[w] / mean_ - 1.0) / (options.overload - 1.0), 1.0, kMaxCapFactor);
    cap_[w] = static_cast<int>(std::min(factor * options.max_cells_per_move, 1e9));
  }
}

std::vector<WorldId> CessionPlanner::recipients_of(WorldId g, bool givers_too) const {
  const int k = grid_.world_count();
  const double cells_per_world = static_cast<double>(grid_.box().count()) / k;
  std::vector<std::tuple<double, std::uint64_t, WorldId>> ranked;
  for (WorldId r : view_.map->neighbours(g)) {
    if ((role(r) == Role::Giver && !givers_too) || !(load(r) < load(g))) continue;
    const double priority = load(r) / mean_ +
                            kNeighbourWeight * static_cast<double>(view_.map->neighbours(r).size()) / k +
                            kSurfaceWeight * static_cast<double>(grid_.cell_count(r)) / cells_per_world;
    ranked.emplace_back(priority, tie_break(options_.seed, view_.step, static_cast<std::uint64_t>(r)), r);
  }
  std::sort(ranked.begin(), ranked.end());
  std::vector<WorldId> out;
  for (const auto& entry : ranked) out.push_back(std::get<2>(entry));
  return out;
}

bool CessionPlanner::eligible(const CellCoord& c, WorldId g, WorldId r) const {
  // Rule c (never reverse the imbalance) before rule b: the flood fill of
  // removable() is the costly test.
  if (moved_[box_index(c)] || grid_.owner(c) != g || !grid_.touches(c, r)) return false;
  return load(g) - cost_in(g, c) >= load(r) + cost_in(r, c) && grid_.removable(c, g);
}

double CessionPlanner::score(const CellCoord& c, WorldId g, WorldId r, double want, double scale) const {
  const double gain = scale > 0 ? std::min(cost_in(g, c), want) / scale : 0.0;
  const FaceCounts f = grid_.faces(c, g, r);
  const double shape = (f.recipient - f.giver) / 6.0;
  const double foreign = grid_.foreign_neighbours(c, g) / 26.0;
  return kGainWeight * gain + kShapeWeight * shape + kForeignWeight * foreign;
}

void CessionPlanner::move(const CellCoord& c, WorldId from, WorldId to) {
  load_[static_cast<std::size_t>(from)] -= cost_in(from, c);
  load_[static_cast<std::size_t>(to)] += cost_in(to, c);
  grid_.set(c, to);
  moved_[box_index(c)] = 1;
  ++given_[static_cast<std::size_t>(from)];
  role_[static_cast<std::size_t>(from)] = Role::Giver;
  role_[static_cast<std::size_t>(to)] = Role::Recipient;
  moves_.push_back({c, from, to});
}

double CessionPlanner::cede(WorldId g, WorldId r, double want) {
  const CellBox& box = grid_.box();
  std::vector<CellCoord> candidates;  // g's cells touching r
  for (std::size_t i = 0, n = static_cast<std::size_t>(box.count()); i < n; ++i) {
    const CellCoord c = box.cell_at(i);
    if (grid_.owner(c) == g && grid_.touches(c, r)) candidates.push_back(c);
  }
  // eligible(), with rule b's block test cached per candidate: it reads the
  // owners of the cell's 3 x 3 x 3 block only (and g's cell count, checked
  // apart), so a move invalidates the candidates next to the moved cell
  // only. Recomputed for every candidate after every move it cost drift 900
  // on 2 worlds 80 ms of its 106 ms of deciding (perf, 64 balance steps).
  std::vector<signed char> block;  // -1: not known yet
  const auto ok = [&](std::size_t i) {
    const CellCoord& c = candidates[i];
    if (moved_[box_index(c)] || grid_.owner(c) != g || !grid_.touches(c, r)) return false;
    if (!(load(g) - cost_in(g, c) >= load(r) + cost_in(r, c)) || grid_.cell_count(g) <= 1) return false;
    if (block[i] < 0) block[i] = grid_.removable(c, g) ? 1 : 0;
    return block[i] == 1;
  };
  block.assign(candidates.size(), -1);
  double given_cost = 0;
  std::vector<int> distance;  // to g's load, computed when first needed
  while (given(g) < cap(g) && want - given_cost > 0) {
    const double still = want - given_cost;
    // Loaded cells by score; the gain is relative to the most any eligible
    // cell can deliver now, so it ranks cells however fine the grid.
    double scale = 0;
    bool loaded_touching = false;
    std::vector<char> eligible_now(candidates.size(), 0);
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const CellCoord& c = candidates[i];
      eligible_now[i] = ok(i);
      if (grid_.owner(c) != g || !grid_.touches(c, r)) continue;
      if (loaded(g, c)) loaded_touching = true;
      if (loaded(g, c) && eligible_now[i]) scale = std::max(scale, std::min(cost_in(g, c), still));
    }
    bool found = false;
    double best_score = 0;
    std::uint64_t best_tie = 0;
    CellCoord best;
    const auto consider = [&](const CellCoord& c, double s) {
      const std::uint64_t tie = tie_break(options_.seed, view_.step, box_index(c));
      if (!found || s > best_score || (s == best_score && tie < best_tie)) {
        found = true;
        best_score = s;
        best_tie = tie;
        best = c;
      }
    };
    for (std::size_t i = 0; i < candidates.size(); ++i) {
      const CellCoord& c = candidates[i];
      if (!eligible_now[i]) continue;
      if (!loaded(g, c)) {
        // Filler rule: an empty cell only where it shortens the border.
        const FaceCounts f = grid_.faces(c, g, r);
        if (f.recipient <= f.giver) continue;
      }
      consider(c, score(c, g, r, still, scale));
    }
    if (!found && !loaded_touching) {
      // Advance: the empty cells nearest g's load (then the shorter border).
      if (distance.empty()) distance = distance_to_load(g);
      for (std::size_t i = 0; i < candidates.size(); ++i) {
        const CellCoord& c = candidates[i];
        const std::size_t j = box_index(c);
        if (!eligible_now[i] || distance[j] < 0) continue;
        const FaceCounts f = grid_.faces(c, g, r);
        consider(c, -static_cast<double>(distance[j]) + (f.recipient - f.giver) / 12.0);
      }
    }
    if (!found) break;
    given_cost += cost_in(g, best);
    move(best, g, r);
    for (std::size_t i = 0; i < candidates.size(); ++i)
      if (std::abs(candidates[i].x - best.x) <= 1 && std::abs(candidates[i].y - best.y) <= 1 &&
          std::abs(candidates[i].z - best.z) <= 1)
        block[i] = -1;
    for (const CellCoord& d : kFaceOffsets) {
      const CellCoord n = offset(best, d);
      if (grid_.owner(n) == g && std::find(candidates.begin(), candidates.end(), n) == candidates.end()) {
        candidates.push_back(n);
        block.push_back(-1);
      }
    }
  }
  return given_cost;
}

void CessionPlanner::tidy() {
  const CellBox& box = grid_.box();
  for (std::size_t i = 0, n = static_cast<std::size_t>(box.count()); i < n; ++i) {
    const CellCoord e = box.cell_at(i);
    const WorldId g = grid_.owner(e);
    if (moved_[i] || loaded(g, e)) continue;
    WorldId r = kNoWorld;  // the one world whose loaded cells e touches
    bool single = true;
    for (const CellCoord& d : kFaceOffsets) {
      const CellCoord f = offset(e, d);
      const WorldId o = grid_.owner(f);
      if (o == kNoWorld || !loaded(o, f)) continue;
      if (r == kNoWorld) r = o;
      else if (o != r) single = false;
    }
    if (r == kNoWorld || r == g || !single || load(r) > load(g) || !grid_.removable(e, g)) continue;
    load_[static_cast<std::size_t>(g)] -= cost_in(g, e);
    load_[static_cast<std::size_t>(r)] += cost_in(r, e);
    grid_.set(e, r);
    moved_[i] = 1;
    moves_.push_back({e, g, r});
  }
}

std::vector<int> CessionPlanner::distance_to_load(WorldId g) const {
  const CellBox& box = grid_.box();
  const std::size_t n = static_cast<std::size_t>(box.count());
  std::vector<int> d(n, -1);
  std::vector<std::size_t> queue;
  for (std::size_t i = 0; i < n; ++i)
    if (grid_.owner(box.cell_at(i)) == g && loaded(g, box.cell_at(i))) {
      d[i] = 0;
      queue.push_back(i);
    }
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const CellCoord c = box.cell_at(queue[head]);
    for (const CellCoord& o : kFaceOffsets) {
      const CellCoord nb = offset(c, o);
      if (grid_.owner(nb) != g) continue;
      const std::size_t j = box.index(nb);
      if (d[j] >= 0) continue;
      d[j] = d[queue[head]] + 1;
      queue.push_back(j);
    }
  }
  return d;
}

bool CessionPlanner::relocate(WorldId u, WorldId h) {
  const CellBox& box = grid_.box();
  // 1. Plan the bestowal on a copy: peel u's cells from the outside in, each
  //    to the least loaded world it touches (then most faces, then lowest
  //    id) among those at or below the mean: the space u leaves must not go
  //    to a loaded world, which a moving load would then enter.
  OwnerGrid after = grid_;
  std::vector<CellCoord> mine;
  for (std::size_t i = 0, n = static_cast<std::size_t>(box.count()); i < n; ++i)
    if (grid_.owner(box.cell_at(i)) == u) mine.push_back(box.cell_at(i));
  std::vector<std::pair<CellCoord, WorldId>> bestowal;
  bool progress = true;
  while (!mine.empty() && progress) {
    progress = false;
    std::vector<CellCoord> left;
    for (const CellCoord& c : mine) {
      WorldId target = kNoWorld;
      int target_faces = 0;
      for (const CellCoord& d : kFaceOffsets) {
        const WorldId o = after.owner(offset(c, d));
        if (o == kNoWorld || o == u || load(o) > mean_) continue;  // never onto a loaded world
        const int faces = after.faces(c, o, kNoWorld).giver;
        if (target == kNoWorld || load(o) < load(target) ||
            (load(o) == load(target) && (faces > target_faces || (faces == target_faces && o < target)))) {
          target = o;
          target_faces = faces;
        }
      }
      if (target == kNoWorld) {
        left.push_back(c);
        continue;
      }
      after.set(c, target);
      bestowal.emplace_back(c, target);
      progress = true;
    }
    mine = std::move(left);
  }
  if (!mine.empty()) return false;
  // 2. The seed: a cell of h (after the bestowal) that h can spare, that
  //    holds load (an empty one would move u for nothing) and whose cost
  //    keeps h at or above u, best by cost delivered and foreign
  //    neighbours (a cell on h's border rather than in its middle).
  double load_u = load(u);
  for (const auto& [c, t] : bestowal) load_u -= cost_in(u, c);
  const double want = std::min(load(h) - mean_, 0.5 * (load(h) - load_u));
  if (!(want > 0)) return false;
  bool found = false;
  double best_score = 0;
  std::uint64_t best_tie = 0;
  CellCoord seed;
  for (std::size_t i = 0, n = static_cast<std::size_t>(box.count()); i < n; ++i) {
    const CellCoord c = box.cell_at(i);
    if (after.owner(c) != h || moved_[i] || !after.removable(c, h)) continue;
    const double cost = cost_in(h, c);
    if (!loaded(h, c) || load(h) - cost < load_u + cost_in(u, c)) continue;
    const double s = kGainWeight * std::min(cost, want) / want + kForeignWeight * after.foreign_neighbours(c, h) / 26.0;
    const std::uint64_t tie = tie_break(options_.seed, view_.step, i);
    if (!found || s > best_score || (s == best_score && tie < best_tie)) {
      found = true;
      best_score = s;
      best_tie = tie;
      seed = c;
    }
  }
  if (!found) return false;
  // 3. Commit: the bestowal, the seed, then h cedes to u as to a neighbour.
  for (const auto& [c, t] : bestowal) move(c, u, t);
  const double seed_cost = cost_in(h, seed);
  move(seed, h, u);
  if (want - seed_cost > 0) cede(h, u, want - seed_cost);
  return true;
}

std::vector<CellMove> CessionPlanner::moves() const {
  std::vector<CellMove> out = moves_;
  std::sort(out.begin(), out.end(), [](const CellMove& a, const CellMove& b) { return a.cell < b.cell; });
  return out;
}

}  // namespace soda::detail
