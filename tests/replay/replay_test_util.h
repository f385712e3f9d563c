// Shared by the replay tests: a small synthetic run (header and frames) and
// a temporary file path.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "soda/replay/view_frame.h"

namespace soda::replay::testing {

/// A path in the temp directory, removed when destroyed.
struct TempPath {
  explicit TempPath(const std::string& name)
      : path((std::filesystem::temp_directory_path() /
              ("soda_replay_" + std::to_string(::getpid()) + "_" + name + ".replay"))
                 .string()) {}
  ~TempPath() { std::filesystem::remove(path); }
  std::string path;
};

/// `dynamic` boxes (and one static ground) over a 2 x 1 x 2 box of cells,
/// `worlds` territories.
inline ViewHeader make_header(std::size_t dynamic, int worlds) {
  ViewHeader h;
  h.scene = "synthetic";
  h.seed = 7;
  h.dt = 1.0 / 60.0;
  h.territories = worlds;
  h.grid = UniformGrid(Vec3(-10, 0, -10), 10.0);
  h.box = CellBox{{0, 0, 0}, {1, 0, 1}};
  ViewBody ground;
  ground.id = 0;
  ground.is_static = true;
  ground.shape = Shape::box(Vec3(50, 0.5, 50));
  ground.position = Vec3(0, -0.5, 0);
  h.bodies.push_back(ground);
  for (std::size_t i = 0; i < dynamic; ++i) {
    ViewBody b;
    b.id = static_cast<BodyId>(i + 1);
    b.shape = i % 2 ? Shape::sphere(0.3) : Shape::box(Vec3(0.5, 0.25, 0.5));
    b.position = Vec3(static_cast<double>(i), 1.0, 0.0);
    b.orientation = Quat(Eigen::AngleAxisd(0.1 * static_cast<double>(i), Vec3::UnitY()));
    h.bodies.push_back(b);
  }
  return h;
}

/// `count` frames of a random walk: some bodies still, some moving, some
/// sleeping, owners and the map changing now and then, one body flying far
/// away once (a keyframe with a new box), busy times, the hash on the last.
inline std::vector<ViewFrame> make_frames(const ViewHeader& h, int count, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> step(-0.05f, 0.05f), unit(-1.f, 1.f);
  const std::size_t n = h.dynamic_count();
  const std::size_t cells = static_cast<std::size_t>(h.box.count());
  ViewFrame f;
  f.position.resize(3 * n);
  f.orientation.resize(4 * n);
  f.sleeping.assign(n, 0);
  f.owner.assign(n, 0);
  f.cell_owner.resize(cells);
  for (std::size_t c = 0; c < cells; ++c) f.cell_owner[c] = static_cast<std::uint16_t>(c % h.territories);
  std::size_t k = 0;
  for (const ViewBody& b : h.bodies) {
    if (b.is_static) continue;
    for (int a = 0; a < 3; ++a) f.position[3 * k + a] = static_cast<float>(b.position[a]);
    f.orientation[4 * k] = static_cast<float>(b.orientation.x());
    f.orientation[4 * k + 1] = static_cast<float>(b.orientation.y());
    f.orientation[4 * k + 2] = static_cast<float>(b.orientation.z());
    f.orientation[4 * k + 3] = static_cast<float>(b.orientation.w());
    f.owner[k] = static_cast<std::uint16_t>(k % h.territories);
    ++k;
  }
  std::vector<ViewFrame> out;
  for (int t = 0; t < count; ++t) {
    f.step = 3 * t + (t > 10 ? 5 : 0);  // gaps: steps need not be consecutive
    for (std::size_t i = 0; i < n; ++i) {
      if (i % 3 == 0) continue;  // a third never moves
      f.sleeping[i] = (t / 20 + i) % 4 == 0;
      if (f.sleeping[i]) continue;
      for (int a = 0; a < 3; ++a) f.position[3 * i + a] += step(rng);
      float q[4];
      double norm = 0;
      for (float& c : q) {
        c = unit(rng);
        norm += static_cast<double>(c) * c;
      }
      for (int a = 0; a < 4; ++a) f.orientation[4 * i + a] = static_cast<float>(q[a] / std::sqrt(norm));
    }
    if (t == 50) f.position[3 * 1 + 1] = 500.f;  // leaves the box: a keyframe with a new box
    if (t % 17 == 5) f.owner[(t * 7) % n] = static_cast<std::uint16_t>((t / 17) % h.territories);
    const bool map_changes = t == 40 || t == 41;
    if (map_changes) f.cell_owner[0] = static_cast<std::uint16_t>((f.cell_owner[0] + 1) % h.territories);
    ViewFrame copy = f;
    if (t > 0 && !map_changes && t % 9 != 0) copy.cell_owner.clear();  // sometimes repeated, mostly not
    copy.world_busy_ms.clear();
    if (t % 4 != 3)
      for (int w = 0; w < h.territories; ++w) copy.world_busy_ms.push_back(0.5f * static_cast<float>(w + t));
    if (t == count - 1) copy.state_hash = 0x0123456789abcdefULL;
    out.push_back(std::move(copy));
  }
  return out;
}

/// Bodies come and go: frames of `h` (make_frames over its dynamic bodies
/// and the `added` ones) in which each added body is alive from frame
/// count / 3 + its index on, body `gone` (a header body) is removed at frame
/// count / 2, and the first added body again at frame 2 * count / 3. A
/// frame whose bodies are the header's has no ids. `added`: dynamic
/// bodies with ids above the header's (their descriptions).
inline std::vector<ViewFrame> make_population_frames(const ViewHeader& h, const std::vector<ViewBody>& added,
                                                     BodyId gone, int count, std::uint64_t seed) {
  ViewHeader all = h;
  for (const ViewBody& b : added) all.bodies.push_back(b);
  std::vector<BodyId> universe, header_ids;
  for (const ViewBody& b : all.bodies)
    if (!b.is_static) universe.push_back(b.id);
  for (const ViewBody& b : h.bodies)
    if (!b.is_static) header_ids.push_back(b.id);
  std::vector<ViewFrame> out;
  const std::vector<ViewFrame> frames = make_frames(all, count, seed);
  for (int t = 0; t < count; ++t) {
    const ViewFrame& f = frames[static_cast<std::size_t>(t)];
    auto alive = [&](BodyId id) {
      for (std::size_t k = 0; k < added.size(); ++k)
        if (added[k].id == id)
          return t >= count / 3 + static_cast<int>(k) && !(k == 0 && t >= 2 * count / 3);
      return !(id == gone && t >= count / 2);
    };
    ViewFrame g;
    g.step = f.step;
    std::vector<BodyId> ids;
    g.cell_owner = f.cell_owner;
    g.world_busy_ms = f.world_busy_ms;
    g.state_hash = f.state_hash;
    for (std::size_t i = 0; i < universe.size(); ++i) {
      if (!alive(universe[i])) continue;
      ids.push_back(universe[i]);
      g.position.insert(g.position.end(), f.position.begin() + 3 * i, f.position.begin() + 3 * i + 3);
      g.orientation.insert(g.orientation.end(), f.orientation.begin() + 4 * i, f.orientation.begin() + 4 * i + 4);
      g.sleeping.push_back(f.sleeping[i]);
      g.owner.push_back(f.owner[i]);
    }
    if (ids != header_ids) g.ids = std::move(ids);
    out.push_back(std::move(g));
  }
  return out;
}

/// Two bodies an input adds to make_header's scene: a box and a capsule,
/// ids 1000 and 1001.
inline std::vector<ViewBody> added_bodies() {
  ViewBody box, capsule;
  box.id = 1000;
  box.shape = Shape::box(Vec3(2.0, 0.5, 1.0));
  box.position = Vec3(3, 5, 3);
  capsule.id = 1001;
  capsule.shape = Shape::capsule(0.25, 1.5);
  capsule.position = Vec3(-3, 5, 3);
  capsule.orientation = Quat(Eigen::AngleAxisd(0.5, Vec3::UnitX()));
  return {box, capsule};
}

/// Bitwise equality of two frames (floats compared as bits), the bodies
/// they hold (ids) included.
inline void expect_same(const ViewFrame& a, const ViewFrame& b) {
  EXPECT_EQ(a.step, b.step);
  EXPECT_EQ(a.ids, b.ids) << a.step;
  ASSERT_EQ(a.position.size(), b.position.size()) << a.step;
  EXPECT_EQ(0, std::memcmp(a.position.data(), b.position.data(), a.position.size() * sizeof(float))) << a.step;
  ASSERT_EQ(a.orientation.size(), b.orientation.size());
  EXPECT_EQ(0, std::memcmp(a.orientation.data(), b.orientation.data(), a.orientation.size() * sizeof(float)));
  EXPECT_EQ(a.sleeping, b.sleeping) << a.step;
  EXPECT_EQ(a.owner, b.owner) << a.step;
  EXPECT_EQ(a.cell_owner, b.cell_owner) << a.step;
  EXPECT_EQ(a.world_busy_ms, b.world_busy_ms) << a.step;
  EXPECT_EQ(a.state_hash, b.state_hash) << a.step;
}

}  // namespace soda::replay::testing
