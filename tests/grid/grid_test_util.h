// Helpers for the grid/ tests: hand-built scenes (independent of the scene
// generators), an independent connectivity check, and error matching.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <functional>
#include <initializer_list>
#include <queue>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda::test {

inline Body cube(BodyId id, const Vec3& position, double half = 0.5) {
  Body b;
  b.id = id;
  b.shape = Shape::box(Vec3::Constant(half));
  b.position = position;
  return b;
}

inline double uniform(std::mt19937_64& rng, double lo, double hi) {
  return lo + (hi - lo) * (static_cast<double>(rng() >> 11) * 0x1.0p-53);
}

/// n unit cubes uniformly in [-size/2, size/2]^3, plus one static ground box.
inline Scene scattered_scene(int n, std::uint64_t seed, double size = 20.0) {
  Scene s;
  s.name = "scattered";
  std::mt19937_64 rng(seed);
  for (int i = 0; i < n; ++i) {
    const Vec3 p(uniform(rng, -size / 2, size / 2), uniform(rng, -size / 2, size / 2),
                 uniform(rng, -size / 2, size / 2));
    s.bodies.push_back(cube(static_cast<BodyId>(i + 1), p));
  }
  Body ground = cube(0, Vec3(0, -size, 0), 100.0);
  ground.is_static = true;
  ground.mass = 0.0;
  s.bodies.push_back(ground);
  return s;
}

/// n unit cubes in three tight, unequal clusters far apart, plus 5 outliers.
inline Scene clustered_scene(int n, std::uint64_t seed) {
  Scene s;
  s.name = "clustered";
  std::mt19937_64 rng(seed);
  const Vec3 centres[3] = {Vec3(-20, 0, 0), Vec3(15, 5, 0), Vec3(0, 0, 25)};
  const double weights[3] = {0.6, 0.3, 0.1};
  BodyId id = 1;
  for (int c = 0; c < 3; ++c)
    for (int i = 0; i < static_cast<int>(n * weights[c]); ++i) {
      const Vec3 d(uniform(rng, -3, 3), uniform(rng, -3, 3), uniform(rng, -3, 3));
      s.bodies.push_back(cube(id++, centres[c] + d));
    }
  for (int i = 0; i < 5; ++i)
    s.bodies.push_back(cube(id++, Vec3(uniform(rng, -30, 30), 30.0, uniform(rng, -30, 30))));
  return s;
}

/// 6-connected pieces of a world's cells within `box` (any box, owners taken
/// from map.owner, so cells outside the map box are included).
inline int pieces_in(const TerritoryMap& map, WorldId world, const CellBox& box) {
  std::set<CellCoord> seen;
  int pieces = 0;
  for (int x = box.lo.x; x <= box.hi.x; ++x)
    for (int y = box.lo.y; y <= box.hi.y; ++y)
      for (int z = box.lo.z; z <= box.hi.z; ++z) {
        const CellCoord start{x, y, z};
        if (map.owner(start) != world || seen.count(start)) continue;
        ++pieces;
        std::queue<CellCoord> q;
        q.push(start);
        seen.insert(start);
        while (!q.empty()) {
          const CellCoord c = q.front();
          q.pop();
          for (int axis = 0; axis < 3; ++axis)
            for (int d : {-1, 1}) {
              CellCoord n = c;
              n[axis] += d;
              if (box.contains(n) && !seen.count(n) && map.owner(n) == world) {
                seen.insert(n);
                q.push(n);
              }
            }
        }
      }
  return pieces;
}

/// Expects f to throw GridError whose message contains every needle.
inline void expect_grid_error(const std::function<void()>& f,
                              std::initializer_list<std::string> needles) {
  try {
    f();
    ADD_FAILURE() << "expected GridError, nothing was thrown";
  } catch (const GridError& e) {
    const std::string what = e.what();
    for (const std::string& needle : needles)
      EXPECT_NE(what.find(needle), std::string::npos)
          << "message '" << what << "' lacks '" << needle << "'";
  } catch (const std::exception& e) {
    ADD_FAILURE() << "expected GridError, got another exception: " << e.what();
  }
}

}  // namespace soda::test
