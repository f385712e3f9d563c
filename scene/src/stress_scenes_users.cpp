// Stress scenes users meet (docs/stress.md): a house of planks, a heavy
// box dropped on a tower, a chain of touching spheres pushed, boxes of
// 0.05 m and 10 m together. Masses are 1 kg per unit-box volume unless said.
#include "generators.h"

namespace soda::detail {

Scene make_card_house(const SceneParams& params) {
  Scene scene = start_scene("card-house", params);
  const int storeys = count_or_default(params, 5, 20);
  // Each storey: two upright planks 0.1 x 1 x 1 m standing on their 0.1 m
  // edge at x = +-0.45, and a lid plank 1.2 x 0.1 x 1 m on them; the next
  // storey stands on the lid. Every face rests exactly on the one below.
  constexpr double kThick = 0.1, kHeight = 1.0, kDepth = 1.0, kLidWidth = 1.2;
  scene.bodies.push_back(flat_ground(kLidWidth + kGroundMargin, 0.5));
  BodyId id = 1;
  double base = 0.0;
  for (int s = 0; s < storeys; ++s) {
    for (double x : {-0.45, 0.45})
      scene.bodies.push_back(dynamic_box(id++, Vec3(0.5 * kThick, 0.5 * kHeight, 0.5 * kDepth), kThick * kHeight * kDepth,
                                         Vec3(x, base + 0.5 * kHeight, 0.0)));
    scene.bodies.push_back(dynamic_box(id++, Vec3(0.5 * kLidWidth, 0.5 * kThick, 0.5 * kDepth),
                                       kLidWidth * kThick * kDepth, Vec3(0.0, base + kHeight + 0.5 * kThick, 0.0)));
    base += kHeight + kThick;
  }
  return scene;
}

Scene make_heavy_drop(const SceneParams& params) {
  Scene scene = start_scene("heavy-drop", params);
  const int k = count_or_default(params, 10, 50);
  constexpr double kHeavyMass = 100.0;  // kg, on 1 kg boxes
  constexpr double kDropHeight = 1.0;   // m between the top box and the heavy box's bottom face
  scene.bodies.push_back(flat_ground(0.5 + kGroundMargin, 0.5));
  const Vec3 half = Vec3::Constant(0.5);
  for (int i = 0; i < k; ++i)
    scene.bodies.push_back(dynamic_box(static_cast<BodyId>(i + 1), half, 1.0, Vec3(0.0, 0.5 + i, 0.0)));
  scene.bodies.push_back(dynamic_box(static_cast<BodyId>(k + 1), half, kHeavyMass, Vec3(0.0, k + kDropHeight + 0.5, 0.0)));
  return scene;
}

Scene make_sphere_chain(const SceneParams& params) {
  Scene scene = start_scene("sphere-chain", params);
  const int n = count_or_default(params, 100, 1000);
  constexpr double kRadius = 0.5;
  constexpr double kPush = 5.0;  // m/s along +x, the first sphere
  // Spheres touching along x from x = 0; the ground long enough for the
  // chain to move 2 m per sphere.
  scene.bodies.push_back(flat_ground(2.0 * n + kGroundMargin, 0.5));
  for (int i = 0; i < n; ++i) {
    Body b = dynamic_sphere(static_cast<BodyId>(i + 1), kRadius, 1.0, Vec3(2.0 * kRadius * i, kRadius, 0.0));
    if (i == 0) b.linear_velocity = Vec3(kPush, 0.0, 0.0);
    scene.bodies.push_back(b);
  }
  return scene;
}

Scene make_mixed_sizes(const SceneParams& params) {
  Scene scene = start_scene("mixed-sizes", params);
  const int per_side = count_or_default(params, 5, 20);  // small boxes per row, on the big box and around it
  constexpr double kBigHalf = 5.0;     // a 10 m box, 1000 kg
  constexpr double kSmallHalf = 0.025; // 0.05 m boxes, 0.1 kg (a 1:10,000 mass ratio)
  constexpr double kSmallMass = 0.1;
  scene.bodies.push_back(flat_ground(2.0 * kBigHalf + kGroundMargin, 0.5));
  scene.bodies.push_back(dynamic_box(1, Vec3::Constant(kBigHalf), 1000.0, Vec3(0.0, kBigHalf, 0.0)));
  BodyId id = 2;
  const Vec3 small = Vec3::Constant(kSmallHalf);
  const double spacing = 1.6 * kBigHalf / per_side;
  for (int i = 0; i < per_side; ++i)
    for (int j = 0; j < per_side; ++j) {
      const double x = (i - 0.5 * (per_side - 1)) * spacing, z = (j - 0.5 * (per_side - 1)) * spacing;
      // On the big box's top face, and on the ground in front of it (x > 6 m).
      scene.bodies.push_back(dynamic_box(id++, small, kSmallMass, Vec3(x, 2.0 * kBigHalf + kSmallHalf, z)));
      scene.bodies.push_back(
          dynamic_box(id++, small, kSmallMass, Vec3(kBigHalf + 1.0 + (i + 0.5) * spacing * 0.5, kSmallHalf, z)));
    }
  return scene;
}

}  // namespace soda::detail
