// Internal: border culling's safe box (TerritoryWorld::predict, docs/skip.md
// "Border culling").
#pragma once

#include <cmath>

#include "territory_world_parts.h"

namespace soda {

/// Rounding guard of a safe box, relative to the magnitudes involved: cell_of
/// computes floor((p - origin) / cell_size) in double, a few ulps (~1e-16
/// relative) from the exact value, so a halo this far inside a box whose
/// faces lie on cell boundaries lands in the box's cells whatever the
/// rounding.
constexpr double kSafeBoxGuard = 1e-9;

/// Sets `e`'s safe box to the 27 cells around `mid`, an interior cell of the
/// world owning `e` (itself and its 26 neighbours owned there), shrunk by
/// the guard: a halo inside it overlaps owned cells only, so predict needs
/// not look its cells up. The map of a world never changes, so the box stays
/// valid for the entry's life.
inline void set_safe_box(TerritoryWorld::Entry& e, const UniformGrid& grid, const CellCoord& mid) {
  const Vec3 lo = grid.cell_min(CellCoord{mid.x - 1, mid.y - 1, mid.z - 1});
  const Vec3 hi = grid.cell_min(CellCoord{mid.x + 2, mid.y + 2, mid.z + 2});
  for (int a = 0; a < 3; ++a) {
    const double scale = grid.cell_size() + std::fabs(grid.origin()[a]);
    e.safe_lo[a] = lo[a] + kSafeBoxGuard * (scale + std::fabs(lo[a]));
    e.safe_hi[a] = hi[a] - kSafeBoxGuard * (scale + std::fabs(hi[a]));
  }
}

}  // namespace soda
