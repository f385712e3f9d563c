#include "churn_policy.h"

#include <set>

namespace soda::detail {

ChurnPolicy::ChurnPolicy(const BalanceOptions& options)
    : cells_per_step_(options.max_cells_per_move), random_(options.seed) {}

std::uint64_t ChurnPolicy::draw(std::uint64_t bound) { return random_() % bound; }

std::vector<CellMove> ChurnPolicy::decide(const LoadView& view) {
  std::vector<CellMove> moves;
  if (!view.map || view.map->world_count() < 2) return moves;
  const TerritoryMap& map = *view.map;
  const CellBox& box = map.box();
  std::set<std::size_t> taken;  // box indices already moved this step
  std::vector<std::size_t> loaded(view.cells.size());
  for (std::size_t i = 0; i < loaded.size(); ++i) loaded[i] = i;
  for (int n = 0; n < cells_per_step_; ++n) {
    CellCoord cell;
    if (!loaded.empty()) {  // a cell holding bodies, not drawn yet
      const std::size_t j = static_cast<std::size_t>(draw(loaded.size()));
      cell = view.cells[loaded[j]].cell;
      loaded[j] = loaded.back();
      loaded.pop_back();
    } else {
      const std::size_t count = static_cast<std::size_t>(box.count());
      if (taken.size() >= count) break;
      std::size_t i = static_cast<std::size_t>(draw(count));
      while (taken.count(i)) i = (i + 1) % count;  // the next free cell
      cell = box.cell_at(i);
    }
    if (!taken.insert(box.index(cell)).second) continue;
    const WorldId from = map.owner(cell);
    const std::vector<WorldId>& neighbours = map.neighbours(from);
    WorldId to;
    if (neighbours.empty() || draw(kAnyWorldOneIn) == 0) {
      to = static_cast<WorldId>(draw(static_cast<std::uint64_t>(map.world_count() - 1)));
      if (to >= from) ++to;  // any world but the owner
    } else {
      to = neighbours[static_cast<std::size_t>(draw(neighbours.size()))];
    }
    moves.push_back(CellMove{cell, from, to});
  }
  return moves;
}

}  // namespace soda::detail
