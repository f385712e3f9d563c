// rain — bodies entering over time into one region (docs/scenes.md): the scene holds the floor, a bin at one end of it, resting
// floor markers over the rest (they hold the map box over the whole floor,
// shared-rules 1 of moving_load_scenes.cpp) and the first wave of falling
// cubes; the other waves are user inputs (add_body at their steps,
// make_rain_inputs), which an application or `soda run --inputs` gives
// through the same calls as the embedding API. The load grows in the bin
// while the rest of the floor sleeps.
//
// A wave: w = ceil(N / kWaves) cubes (fewer in the last, until N are in), each at a lattice point of the bin
// (pitch kLatticePitch, a seeded choice of w points of the m x m lattice,
// seeded jitter and orientation), all at height H falling at kDropSpeed.
// Waves kWaveEvery steps apart: a cube has fallen kDropSpeed t + g t^2 / 2
// = 2.7 m by the next wave, more than a cube's bounding diameter (1.73 m),
// so a new cube never overlaps the one spawned above the same point before.
#include <algorithm>
#include <cmath>
#include <numeric>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kWaves = 16;
constexpr int kWaveEvery = 30;           // steps between waves: 0, 30, ..., 450
constexpr double kDropSpeed = 3.0;       // m/s downwards at spawn
constexpr double kLatticePitch = 2.0;    // m: a cube (bounding diameter 1.73 m) and 0.27 m to spare
constexpr double kJitter = 0.1;          // m, either way, in x and z
constexpr double kLatticeSlack = 1.5;    // lattice points per cube of a wave: the choice is random
constexpr double kMarkerPitch = 4.0;     // m between floor markers
constexpr double kBinWallHeight = 3.0;   // m
constexpr double kSettleSeconds = 2.5;   // after the last wave: land, settle

struct RainLayout {
  int n = 0;            // cubes in all waves
  int per_wave = 0;     // w
  int lattice = 0;      // m (points per axis)
  double side = 0;      // bin inner side, m; the bin spans x in [0, side], z in [-side/2, side/2]
  double floor = 0;     // the floor spans x in [-kGroundMargin, floor]
  double height = 0;    // spawn height of the cubes' centres, m
};

RainLayout layout(const SceneParams& params) {
  RainLayout l;
  l.n = count_or_default(params, 400, 20000);
  l.per_wave = (l.n + kWaves - 1) / kWaves;
  l.lattice = std::max(4, static_cast<int>(std::ceil(std::sqrt(kLatticeSlack * l.per_wave))));
  l.side = l.lattice * kLatticePitch;
  l.floor = 4.0 * l.side;
  // Above the heap: loose unit cubes stack about 1.6 m per cube per m^2.
  l.height = 8.0 + 1.6 * l.n / (l.side * l.side);
  return l;
}

// The cubes of wave j (0 .. kWaves-1) with ids from first_id; wave 0 is
// part of the scene, the others are inputs. Every wave draws from its own
// generator (seed, wave), so the scene and the inputs agree on it.
std::vector<Body> wave(const RainLayout& l, std::uint64_t seed, int j, BodyId first_id) {
  const int count = std::min(l.per_wave, l.n - j * l.per_wave);
  if (count <= 0) return {};
  SceneRandom rng(seed * 1000003ULL + static_cast<std::uint64_t>(j));
  std::vector<int> points(static_cast<std::size_t>(l.lattice * l.lattice));
  std::iota(points.begin(), points.end(), 0);
  for (std::size_t i = 0; i + 1 < points.size(); ++i) {  // Fisher-Yates with the scene's own uniform
    const auto r = i + static_cast<std::size_t>(rng.unit() * static_cast<double>(points.size() - i));
    std::swap(points[i], points[std::min(r, points.size() - 1)]);
  }
  std::sort(points.begin(), points.begin() + count);  // ids in lattice order
  std::vector<Body> out;
  for (int k = 0; k < count; ++k) {
    const int p = points[static_cast<std::size_t>(k)];
    const double x = (p / l.lattice + 0.5) * kLatticePitch + rng.uniform(-kJitter, kJitter);
    const double z = (p % l.lattice + 0.5) * kLatticePitch - 0.5 * l.side + rng.uniform(-kJitter, kJitter);
    Body cube = dynamic_box(first_id + static_cast<BodyId>(k), kUnitHalf, 1.0, Vec3(x, l.height, z), rng.rotation());
    cube.linear_velocity = Vec3(0.0, -kDropSpeed, 0.0);
    out.push_back(cube);
  }
  return out;
}

}  // namespace

Scene make_rain(const SceneParams& params) {
  const RainLayout l = layout(params);
  Scene scene;
  scene.name = "rain";
  scene.seed = params.seed;
  const double half_floor = 0.5 * (l.floor + kGroundMargin) + kGroundMargin;
  scene.bodies.push_back(flat_ground(half_floor, 0.5, 0.5 * (l.floor - kGroundMargin)));
  // The bin: walls 0.5 m thick around x in [0, side], z in [-side/2, side/2].
  const double hw = 0.25, hh = 0.5 * kBinWallHeight, hs = 0.5 * l.side;
  BodyId id = 1;
  scene.bodies.push_back(static_box(id++, Vec3(hw, hh, hs + 2 * hw), Vec3(-hw, hh, 0.0)));
  scene.bodies.push_back(static_box(id++, Vec3(hw, hh, hs + 2 * hw), Vec3(l.side + hw, hh, 0.0)));
  scene.bodies.push_back(static_box(id++, Vec3(hs, hh, hw), Vec3(hs, hh, -hs - hw)));
  scene.bodies.push_back(static_box(id++, Vec3(hs, hh, hw), Vec3(hs, hh, hs + hw)));
  // Floor markers: resting cubes on a 4 m lattice over the floor beyond the
  // bin (x from side + 4 to the floor's end, the bin's width in z).
  for (double x = l.side + kMarkerPitch; x <= l.floor; x += kMarkerPitch)
    for (double z = -hs + 0.5 * kMarkerPitch; z < hs; z += kMarkerPitch)
      scene.bodies.push_back(dynamic_box(id++, kUnitHalf, 1.0, Vec3(x, 0.5, z)));
  for (const Body& b : wave(l, params.seed, 0, id)) scene.bodies.push_back(b);
  scene.settings.steps = (kWaves - 1) * kWaveEvery + static_cast<int>(std::ceil(kSettleSeconds / scene.settings.dt));
  return scene;
}

std::vector<UserInput> make_rain_inputs(const SceneParams& params) {
  const RainLayout l = layout(params);
  const Scene scene = make_rain(params);
  BodyId next = 0;
  for (const Body& b : scene.bodies) next = std::max(next, b.id + 1);
  std::vector<UserInput> inputs;
  for (int j = 1; j < kWaves; ++j)
    for (const Body& b : wave(l, params.seed, j, next)) {
      UserInput in;
      in.kind = UserInput::Kind::AddBody;
      in.step = static_cast<std::int64_t>(j) * kWaveEvery;
      in.sequence = inputs.size();
      in.body = b;
      inputs.push_back(in);
      ++next;
    }
  return inputs;
}

}  // namespace soda::detail
