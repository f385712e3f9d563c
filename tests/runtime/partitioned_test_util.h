// Shared helpers of the runtime/ suites: the one-world reference, partitioned
// runs, and — when hashes differ — the first step and body that differ.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <sstream>
#include <string>
#include <vector>

#include "soda/grid/partition.h"
#include "soda/runtime/partitioned_world.h"
#include "soda/scene/registry.h"
#include "soda/worlds/canonical_world.h"

namespace soda::test {

/// 2 m cells from the origin: borders at x, y, z = 0 (and every 2 m), where
/// the border and stress scenes put their contacts.
inline GridOptions border_grid() {
  GridOptions g;
  g.cell_size = 2.0;
  g.origin = Vec3::Zero();
  return g;
}

inline Scene scene(const std::string& name, int n, std::uint64_t seed = 1) {
  return make_scene(name, SceneParams{n, seed, false});
}

/// state_hash of the one-world reference after `steps` steps.
inline std::uint64_t reference_hash(const Scene& s, int steps) {
  CanonicalWorld w(s);
  for (int i = 0; i < steps; ++i) w.step();
  return w.state_hash();
}

inline bool same_bits(const BodyState& a, const BodyState& b) { return std::memcmp(&a, &b, sizeof a) == 0; }

/// Steps the reference and a partitioned run side by side and describes the
/// first step and bodies that differ ("" if none within `steps`).
inline std::string first_divergence(const Scene& s, const TerritoryMap& map, int steps,
                                    PartitionedOptions options = {}) {
  CanonicalWorld ref(s);
  PartitionedWorld part(s, map, options);
  for (int t = 1; t <= steps; ++t) {
    ref.step();
    part.step(1);
    const std::vector<BodyState> a = ref.body_states();
    const std::vector<BodyState> b = part.body_states();
    if (a.size() != b.size()) return "step " + std::to_string(t) + ": body counts differ";
    std::ostringstream out;
    int shown = 0;
    for (std::size_t i = 0; i < a.size() && shown < 5; ++i) {
      if (same_bits(a[i], b[i])) continue;
      ++shown;
      out << "step " << t << " body " << a[i].id << ": ref origin (" << a[i].origin[0] << ", " << a[i].origin[1]
          << ", " << a[i].origin[2] << ") v (" << a[i].linear_velocity[0] << ", " << a[i].linear_velocity[1] << ", "
          << a[i].linear_velocity[2] << ") act " << a[i].activation_state << " | part origin (" << b[i].origin[0]
          << ", " << b[i].origin[1] << ", " << b[i].origin[2] << ") v (" << b[i].linear_velocity[0] << ", "
          << b[i].linear_velocity[1] << ", " << b[i].linear_velocity[2] << ") act " << b[i].activation_state
          << "; ";
    }
    if (shown) return out.str();
  }
  return "";
}

/// A scene of the fuzz and speculation suites with the partition it runs
/// on; border scenes use 2 m cells at the origin (the chain a box of them).
struct Case {
  const char* scene;
  int n;
  const char* partition;
  int territories;
  bool border_grid;
};

inline GridOptions grid_of(const Case& c) {
  GridOptions g;
  if (c.border_grid) {
    g.cell_size = 2.0;
    g.origin = Vec3::Zero();
    if (std::string(c.scene) == "chain") g.box = CellBox{{-4, 0, -1}, {3, 0, 0}};
  }
  return g;
}

inline TerritoryMap map_of(const Case& c, const Scene& s) {
  return make_partition(c.partition, s, c.territories, grid_of(c));
}

/// falling-cubes, cube-pile, seam-stack, cross-traffic, projectile, chain.
inline const std::vector<Case>& mixed_cases() {
  static const std::vector<Case> all = {
      {"falling-cubes", 150, "kmeans", 4, false}, {"cube-pile", 150, "rcb", 3, false},
      {"seam-stack", 0, "grid:2x1x2", 4, true},   {"cross-traffic", 0, "grid:2x1x2", 4, true},
      {"projectile", 0, "kmeans", 8, true},       {"chain", 16, "grid:8x1x1", 8, true},
  };
  return all;
}

/// Sums of the per-world metrics.
inline WorldMetrics total(const std::vector<WorldMetrics>& ms) { return total_metrics(ms); }

inline std::string summary(const WorldMetrics& t) {
  std::ostringstream s;
  s << "ghosts " << t.ghosts_sent << ", seeded " << t.manifolds_seeded << ", returned " << t.manifolds_returned
    << ", migrations " << t.migrations_out << ", border islands " << t.islands_solved << " (max "
    << t.merged_island_worlds_max << " worlds), relay msgs " << t.relay_messages_sent;
  return s.str();
}

}  // namespace soda::test
