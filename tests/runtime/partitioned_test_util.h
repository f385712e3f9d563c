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
#include "soda/scene/hash_text.h"
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

/// Under ThreadSanitizer (10-20x slower), sweeps over scenes that check
/// the same paths for each run one of them: TSan looks for races, and the
/// Release suite runs every scene.
#if defined(__SANITIZE_THREAD__)
inline constexpr bool kThreadSanitizer = true;
#else
inline constexpr bool kThreadSanitizer = false;
#endif

/// The anticipations a SyncTest sweep runs: lockstep and 8 steps ahead.
/// Under ThreadSanitizer, where such a sweep runs 10-20x slower, only 8:
/// the run in which worlds race each other (the Release suite runs both).
inline std::vector<int> sync_test_anticipations() {
  if (kThreadSanitizer) return {8};
  return {0, 8};
}

/// state_hash of the one-world reference after `steps` steps (parking off,
/// CanonicalWorld's default, unless asked).
inline std::uint64_t reference_hash(const Scene& s, int steps, bool parking = false) {
  CanonicalWorld w(s);
  w.set_parking(parking);
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

/// Churn (random cessions every 10 steps, seeded) on a thread per world,
/// speculating (anticipation 8) under SyncTest, validated: the load-balance
/// case of the scene feature suites.
inline PartitionedOptions churn_options(std::uint64_t seed) {
  PartitionedOptions o;
  o.runtime.validate = true;
  o.runtime.anticipation = 8;
  o.sync_test = 1;
  o.schedule = Schedule::ThreadPerWorld;
  o.runtime.balance.policy = "churn";
  o.runtime.balance.period = 10;
  o.runtime.balance.seed = seed;
  return o;
}

/// A case of a feature's decomposition matrix: K territories (kmeans; a pool
/// of 2 threads above one), anticipation, SyncTest, parking.
struct MatrixCase {
  int territories;
  int anticipation;
  int sync_test;
  bool parking;
};

/// The matrix the decomposition suites of scene features run: K 1 to 8,
/// parking on and off, speculating, under SyncTest.
inline auto decomposition_matrix() {
  return ::testing::Values(MatrixCase{1, 0, 0, true}, MatrixCase{1, 0, 0, false}, MatrixCase{2, 0, 0, true},
                           MatrixCase{4, 0, 0, true}, MatrixCase{8, 0, 0, true}, MatrixCase{4, 0, 0, false},
                           MatrixCase{8, 0, 0, false}, MatrixCase{4, 8, 0, true}, MatrixCase{8, 8, 0, false},
                           MatrixCase{4, 0, 2, true});
}

/// "K4_anticipation8_sync0_parking": the name of a MatrixCase in a suite.
inline std::string matrix_case_name(const MatrixCase& c) {
  return "K" + std::to_string(c.territories) + "_anticipation" + std::to_string(c.anticipation) + "_sync" +
         std::to_string(c.sync_test) + (c.parking ? "_parking" : "_noparking");
}

/// What a matrix run did, for the caller's checks that it exercised the
/// machinery it is about (ghosts, merged islands, bets, rollbacks).
struct MatrixRun {
  WorldMetrics total;
  std::uint64_t sync_rollbacks = 0;
};

/// Runs `s` for `steps` steps on c's partition with the validator on and
/// expects the one-world hash `reference`; on a mismatch under lockstep,
/// names the first step and bodies that differ (a run without inputs).
/// `label` names the scene in the printed line; `inputs` are given to the
/// run before it starts (PartitionedOptions::inputs).
inline MatrixRun expect_one_world_hash(const Scene& s, const char* label, const MatrixCase& c, int steps,
                                       std::uint64_t reference, const std::vector<UserInput>& inputs = {}) {
  const TerritoryMap map = make_partition("kmeans", s, c.territories, GridOptions{});
  PartitionedOptions o;
  o.runtime.anticipation = c.anticipation;
  o.runtime.parking = c.parking;
  o.runtime.validate = true;
  o.sync_test = c.sync_test;
  o.inputs = inputs;
  if (c.territories > 1) {
    o.schedule = Schedule::Pool;
    o.threads = 2;
  }
  PartitionedWorld w(s, map, o);
  w.step(steps);
  const MatrixRun run{total(w.metrics()), w.sync_rollbacks()};
  std::printf("[ %s %s, K %d, anticipation %d, sync-test %d, parking %d ] %s; %s, one world %s\n", label,
              kPrecisionName, c.territories, c.anticipation, c.sync_test, int(c.parking), summary(run.total).c_str(),
              hash_hex(w.state_hash()).c_str(), hash_hex(reference).c_str());
  EXPECT_EQ(hash_hex(w.state_hash()), hash_hex(reference));
  if (w.state_hash() != reference && c.anticipation == 0 && c.sync_test == 0 && inputs.empty()) {
    PartitionedOptions lockstep;
    lockstep.runtime.parking = c.parking;
    ADD_FAILURE() << first_divergence(s, map, steps, lockstep);
  }
  return run;
}

}  // namespace soda::test
