// Synthetic load for the loadbalance suites: a territory map, bodies per
// box cell, and busy times made by a known cost model, so that a test knows
// what a policy should see and can apply its moves and measure again.
#pragma once

#include <algorithm>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "soda/grid/partition.h"
#include "soda/grid/territory_map.h"
#include "soda/loadbalance/cost_model.h"
#include "soda/loadbalance/policy.h"

namespace soda::test {

/// A map of unit cells over `box`, owner(cell) given by a function.
template <typename OwnerOf>
TerritoryMap make_map(const CellBox& box, int worlds, OwnerOf owner_of) {
  std::vector<WorldId> owners(static_cast<std::size_t>(box.count()));
  for (std::size_t i = 0; i < owners.size(); ++i) owners[i] = owner_of(box.cell_at(i));
  return TerritoryMap(UniformGrid(Vec3::Zero(), 1.0), box, std::move(owners), worlds);
}

/// Awake bodies per cell (cells not listed hold none).
using CellBodies = std::map<CellCoord, int>;

/// The view a runtime would gather if busy followed `truth` exactly
/// (every body awake, one contact pair per body).
inline LoadView make_view(const TerritoryMap& map, const CellBodies& bodies, const CostCoefficients& truth,
                          std::int64_t step = 100) {
  LoadView view;
  view.step = step;
  view.map = &map;
  view.worlds.resize(static_cast<std::size_t>(map.world_count()));
  for (WorldId w = 0; w < map.world_count(); ++w) {
    WorldLoad& l = view.worlds[static_cast<std::size_t>(w)];
    l.world = w;
    l.steps = 20;
    l.cells = map.cell_count(w);
  }
  for (const auto& [cell, n] : bodies) {
    const WorldId w = map.owner(cell);
    view.cells.push_back({cell, w, n, n, n});
    WorldLoad& l = view.worlds[static_cast<std::size_t>(w)];
    l.bodies += n;
    l.awake_bodies += n;
    l.contact_pairs += n;
  }
  const CostModel model(truth);
  for (WorldLoad& l : view.worlds) l.busy = model.predict(l);
  return view;
}

/// The map after the moves; fails the test if a move is not from the
/// cell's owner or names a cell twice.
inline TerritoryMap apply(const TerritoryMap& map, const std::vector<CellMove>& moves) {
  std::vector<std::pair<CellCoord, WorldId>> changes;
  for (const CellMove& m : moves) {
    EXPECT_TRUE(map.box().contains(m.cell));
    EXPECT_EQ(map.owner(m.cell), m.from) << to_string(m.cell);
    EXPECT_NE(m.from, m.to);
    changes.emplace_back(m.cell, m.to);
  }
  for (std::size_t i = 1; i < moves.size(); ++i) EXPECT_LT(moves[i - 1].cell, moves[i].cell) << "canonical order, one move per cell";
  return map.reassigned(changes);
}

/// max / mean of the worlds' busy times.
inline double busy_imbalance(const LoadView& view) {
  double sum = 0, top = 0;
  for (const WorldLoad& w : view.worlds) {
    sum += w.busy;
    top = std::max(top, w.busy);
  }
  return top / (sum / static_cast<double>(view.worlds.size()));
}

}  // namespace soda::test
