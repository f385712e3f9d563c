// compounds (docs/scenes.md): chairs and tables made of boxes (compound
// shapes, docs/scene-format.md "Compound shapes") falling in a loose block
// onto a ground and two static tables, across territory borders.
#include <cmath>

#include "generators.h"
#include "random.h"

namespace soda::detail {
namespace {

constexpr int kDefaultPieces = 200;
constexpr double kSpacing = 1.8;  // m between pieces: the widest (a table) is 1.3 m across

CompoundChild part(const Vec3& half_extents, const Vec3& at) {
  return CompoundChild{Shape::box(half_extents), at, Quat::Identity()};
}

// A chair about its seat's centre: a 0.5 m square seat, four legs 0.45 m
// long under its corners, a back 0.55 m high along one edge.
Shape chair() {
  std::vector<CompoundChild> parts;
  parts.push_back(part(Vec3(0.25, 0.03, 0.25), Vec3::Zero()));
  for (double x : {-0.22, 0.22})
    for (double z : {-0.22, 0.22}) parts.push_back(part(Vec3(0.03, 0.225, 0.03), Vec3(x, -0.255, z)));
  parts.push_back(part(Vec3(0.25, 0.275, 0.03), Vec3(0.0, 0.305, -0.22)));
  return Shape::compound(std::move(parts));
}

// A table about its top's centre: a 1.3 x 0.8 m top, four legs 0.7 m long.
Shape table() {
  std::vector<CompoundChild> parts;
  parts.push_back(part(Vec3(0.65, 0.04, 0.4), Vec3::Zero()));
  for (double x : {-0.58, 0.58})
    for (double z : {-0.33, 0.33}) parts.push_back(part(Vec3(0.04, 0.35, 0.04), Vec3(x, -0.39, z)));
  return Shape::compound(std::move(parts));
}

}  // namespace

Scene make_compounds(const SceneParams& params) {
  Scene scene = start_scene("compounds", params);
  SceneRandom rng(params.seed);
  const int n = params.n > 0 ? params.n : kDefaultPieces;
  // A square grid kSpacing apart, in layers 1.9 m apart from y = 2.5 m (pieces are at most 1.76 m across); every
  // third piece a table (8 kg), the others chairs (4 kg), turned at random.
  const int side = static_cast<int>(std::ceil(std::sqrt(n / 3.0)));
  const double half = 0.5 * kSpacing * side;
  scene.bodies.push_back(flat_ground(half + 8.0, 0.5));
  BodyId id = 1;
  // Two static tables on the ground under the block (static compounds).
  for (double x : {-0.3 * half, 0.3 * half}) {
    Body t;
    t.id = id++;
    t.is_static = true;
    t.shape = table();
    t.position = Vec3(x, 0.74, 0.0);
    scene.bodies.push_back(std::move(t));
  }
  for (int i = 0; i < n; ++i) {
    const int layer = i / (side * side), row = (i / side) % side, col = i % side;
    Body b;
    b.id = id++;
    const bool is_table = i % 3 == 2;
    b.shape = is_table ? table() : chair();
    b.mass = is_table ? 8.0 : 4.0;
    b.position = Vec3(-half + 0.5 * kSpacing + kSpacing * col, 2.5 + 1.9 * layer, -half + 0.5 * kSpacing + kSpacing * row);
    b.orientation = rng.rotation();
    scene.bodies.push_back(std::move(b));
  }
  return scene;
}

}  // namespace soda::detail
