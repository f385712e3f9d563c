// Scenes with joints (docs/scenes.md, "Joint scenes"): pendulums,
// chain-bridge, ragdolls, and the joint stress scenes heavy-chain and
// motor-hinge. Every joint is given by a pivot and a frame in the
// world at the bodies' start poses (joint_at below), so that its two local
// frames agree exactly where the scene begins.
#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "generators.h"
#include "random.h"
#include "soda/scene/validate.h"

namespace soda::detail {
namespace {

constexpr double kPi = std::numbers::pi;

const Body& body_with(const Scene& scene, BodyId id) {
  for (const Body& b : scene.bodies)
    if (b.id == id) return b;
  throw SceneError(scene.name + ": no body " + std::to_string(id));
}

// A frame given in the world, in a body's local space at its start pose.
JointFrame local_frame(const Body& b, const Vec3& pivot, const Quat& orientation) {
  const Quat inv = b.orientation.normalized().conjugate();
  JointFrame f;
  f.position = inv * (pivot - b.position);
  f.orientation = (inv * orientation).normalized();
  return f;
}

Joint& joint_at(Scene& scene, JointKind kind, BodyId a, BodyId b, const Vec3& pivot,
                const Quat& orientation = Quat::Identity()) {
  Joint j;
  j.id = static_cast<JointId>(scene.joints.size());
  j.kind = kind;
  j.body_a = a, j.body_b = b;
  j.frame_a = local_frame(body_with(scene, a), pivot, orientation);
  j.frame_b = local_frame(body_with(scene, b), pivot, orientation);
  scene.joints.push_back(j);
  return scene.joints.back();
}

Body capsule(BodyId id, double radius, double height, double mass, const Vec3& position, const Quat& orientation) {
  Body b;
  b.id = id;
  b.shape = Shape::capsule(radius, height);
  b.mass = mass;
  b.position = position;
  b.orientation = orientation;
  return b;
}

// A chain of `links` boxes (0.5 x 0.1 x 0.1 m, 1 kg) joined end to end by
// point-to-point joints, hanging straight down from a static anchor whose
// bottom face is `height` m up; the pivots are 0.5 m apart. Returns the last
// link's id (next id: + 1).
BodyId hanging_links(Scene& scene, int links, double height) {
  constexpr double kLink = 0.5;
  const BodyId anchor = 1;
  scene.bodies.push_back(static_box(anchor, Vec3(0.1, 0.1, 0.1), Vec3(0.0, height + 0.1, 0.0)));
  BodyId previous = anchor;
  for (int i = 0; i < links; ++i) {
    const BodyId id = previous + 1;
    scene.bodies.push_back(dynamic_box(id, Vec3(0.05, 0.5 * kLink, 0.05), 1.0, Vec3(0.0, height - kLink * (i + 0.5), 0.0)));
    joint_at(scene, JointKind::PointToPoint, previous, id, Vec3(0.0, height - kLink * i, 0.0));
    previous = id;
  }
  return previous;
}

}  // namespace

// Four chains of N links (boxes 0.5 x 0.2 x 0.2 m, 1 kg) joined end to end
// by point-to-point joints, hanging from static anchors at x = 0 and held
// out horizontally along +x at the start: they swing down and through
// x = 0, the border of grid:2x1x1.
Scene make_pendulums(const SceneParams& params) {
  Scene scene;
  scene.name = "pendulums";
  scene.seed = params.seed;
  const int n = count_or_default(params, 16, 200);
  constexpr int kChains = 4;
  constexpr double kLink = 0.5;
  const double height = kLink * n + 2.0;
  scene.bodies.push_back(flat_ground(kLink * n + kGroundMargin, 0.5));
  BodyId next = 1;
  for (int c = 0; c < kChains; ++c) {
    const double z = (c - 0.5 * (kChains - 1)) * 1.0;
    const BodyId anchor = next++;
    scene.bodies.push_back(static_box(anchor, Vec3(0.1, 0.1, 0.1), Vec3(0.0, height, z)));
    BodyId previous = anchor;
    for (int i = 0; i < n; ++i) {
      const BodyId id = next++;
      scene.bodies.push_back(dynamic_box(id, Vec3(0.5 * kLink, 0.1, 0.1), 1.0, Vec3(kLink * (i + 0.5), height, z)));
      joint_at(scene, JointKind::PointToPoint, previous, id, Vec3(kLink * i, height, z));
      previous = id;
    }
  }
  return scene;
}

// A bridge of N planks (1 x 0.2 x 2 m, 5 kg) hinged edge to edge about z,
// from a static pillar at x = -N/2 to one at x = +N/2, 5 m above the
// ground, and N / 2 boxes of 0.5 m dropped on it from 1.5..4.5 m above.
Scene make_chain_bridge(const SceneParams& params) {
  Scene scene;
  scene.name = "chain-bridge";
  scene.seed = params.seed;
  const int n = count_or_default(params, 24, 400);
  SceneRandom random(params.seed);
  constexpr double kHeight = 5.0;
  const double half = 0.5 * n;
  scene.bodies.push_back(flat_ground(half + kGroundMargin, 0.5));
  const BodyId left = 1, right = 2;
  scene.bodies.push_back(static_box(left, Vec3(0.5, 0.5 * kHeight, 1.0), Vec3(-half - 0.5, 0.5 * kHeight, 0.0)));
  scene.bodies.push_back(static_box(right, Vec3(0.5, 0.5 * kHeight, 1.0), Vec3(half + 0.5, 0.5 * kHeight, 0.0)));
  BodyId next = 3, previous = left;
  for (int i = 0; i < n; ++i) {
    const BodyId id = next++;
    Body plank = dynamic_box(id, Vec3(0.5, 0.1, 1.0), 5.0, Vec3(-half + i + 0.5, kHeight - 0.1, 0.0));
    scene.bodies.push_back(plank);
    joint_at(scene, JointKind::Hinge, previous, id, Vec3(-half + i, kHeight - 0.1, 0.0));
    previous = id;
  }
  joint_at(scene, JointKind::Hinge, previous, right, Vec3(half, kHeight - 0.1, 0.0));
  const int boxes = std::max(1, n / 2);
  for (int i = 0; i < boxes; ++i) {
    const double x = -half + (i + 0.5) * (2.0 * half / boxes);
    const Vec3 at(x, kHeight + 1.5 + 3.0 * random.unit(), random.uniform(-0.5, 0.5));
    scene.bodies.push_back(dynamic_box(next++, Vec3::Constant(0.25), 1.0, at, random.rotation()));
  }
  return scene;
}

// N ragdolls of 11 capsules (pelvis, spine, head, upper and lower arms and
// legs; 10 joints: cone-twist at the neck, shoulders and hips, hinges at the
// waist, elbows and knees), standing in columns 2 m apart, layers 2 m
// apart, each turned by a seeded yaw, falling into a pile.
Scene make_ragdolls(const SceneParams& params) {
  Scene scene;
  scene.name = "ragdolls";
  scene.seed = params.seed;
  const int n = count_or_default(params, 16, 100000);
  SceneRandom random(params.seed);
  const int columns = std::max(1, static_cast<int>(std::ceil(std::sqrt(n / 4.0))));
  const double half = columns * 1.0;
  scene.bodies.push_back(flat_ground(half + kGroundMargin, 0.5));
  BodyId next = 1;
  const Quat along_x(Eigen::AngleAxisd(kPi / 2, Vec3::UnitZ()));  // a capsule's y axis turned to x
  const Quat hinge_x(Eigen::AngleAxisd(kPi / 2, Vec3::UnitY()));   // a hinge's z axis turned to x
  for (int r = 0; r < n; ++r) {
    const int layer = r / (columns * columns), cell = r % (columns * columns);
    const Vec3 base((cell % columns - 0.5 * (columns - 1)) * 2.0, 0.1 + 2.0 * layer,
                    (cell / columns - 0.5 * (columns - 1)) * 2.0);
    const Quat turn = yaw(random.uniform(-0.3, 0.3));
    auto at = [&](const Vec3& local) { return Vec3(base + turn * local); };
    const BodyId pelvis = next, spine = next + 1, head = next + 2;
    const BodyId leg_up[2] = {next + 3, next + 4}, leg_low[2] = {next + 5, next + 6};
    const BodyId arm_up[2] = {next + 7, next + 8}, arm_low[2] = {next + 9, next + 10};
    next += 11;
    scene.bodies.push_back(capsule(pelvis, 0.15, 0.20, 3.0, at(Vec3(0, 1.0, 0)), turn));
    scene.bodies.push_back(capsule(spine, 0.15, 0.28, 3.0, at(Vec3(0, 1.2, 0)), turn));
    scene.bodies.push_back(capsule(head, 0.10, 0.05, 1.0, at(Vec3(0, 1.6, 0)), turn));
    for (int s = 0; s < 2; ++s) {
      const double side = s == 0 ? -1.0 : 1.0;
      scene.bodies.push_back(capsule(leg_up[s], 0.07, 0.45, 2.0, at(Vec3(0.18 * side, 0.65, 0)), turn));
      scene.bodies.push_back(capsule(leg_low[s], 0.05, 0.37, 1.5, at(Vec3(0.18 * side, 0.2, 0)), turn));
      scene.bodies.push_back(capsule(arm_up[s], 0.05, 0.33, 1.0, at(Vec3(0.35 * side, 1.45, 0)), turn * along_x));
      scene.bodies.push_back(capsule(arm_low[s], 0.04, 0.25, 0.8, at(Vec3(0.7 * side, 1.45, 0)), turn * along_x));
    }
    Joint& waist = joint_at(scene, JointKind::Hinge, pelvis, spine, at(Vec3(0, 1.1, 0)), turn * hinge_x);
    waist.limited = true, waist.lower = -kPi / 4, waist.upper = kPi / 2;
    Joint& neck = joint_at(scene, JointKind::ConeTwist, spine, head, at(Vec3(0, 1.45, 0)), turn * along_x);
    neck.swing_span1 = neck.swing_span2 = kPi / 4, neck.twist_span = kPi / 2;
    for (int s = 0; s < 2; ++s) {
      const double side = s == 0 ? -1.0 : 1.0;
      Joint& hip = joint_at(scene, JointKind::ConeTwist, pelvis, leg_up[s], at(Vec3(0.18 * side, 0.9, 0)),
                            turn * Quat(Eigen::AngleAxisd(-kPi / 2, Vec3::UnitZ())));
      hip.swing_span1 = hip.swing_span2 = kPi / 4, hip.twist_span = 0.0;
      Joint& knee = joint_at(scene, JointKind::Hinge, leg_up[s], leg_low[s], at(Vec3(0.18 * side, 0.42, 0)),
                             turn * hinge_x);
      knee.limited = true, knee.lower = 0.0, knee.upper = kPi / 2;
      Joint& shoulder = joint_at(scene, JointKind::ConeTwist, spine, arm_up[s], at(Vec3(0.15 * side, 1.45, 0)),
                                 turn * (s == 0 ? Quat(Eigen::AngleAxisd(kPi, Vec3::UnitZ())) : Quat::Identity()));
      shoulder.swing_span1 = shoulder.swing_span2 = kPi / 2, shoulder.twist_span = 0.0;
      Joint& elbow = joint_at(scene, JointKind::Hinge, arm_up[s], arm_low[s], at(Vec3(0.55 * side, 1.45, 0)), turn);
      elbow.limited = true;
      elbow.lower = s == 0 ? -kPi / 2 : 0.0, elbow.upper = s == 0 ? 0.0 : kPi / 2;
    }
  }
  return scene;
}

// N links (default 100, N <= 1000) of hanging_links from an anchor 0.5 N + 2 m
// up, at rest, the lowest link pushed along +x at 2 m/s: the chain sways.
Scene make_hanging_chain(const SceneParams& params) {
  Scene scene;
  scene.name = "hanging-chain";
  scene.seed = params.seed;
  const int n = count_or_default(params, 100, 1000);
  scene.bodies.push_back(flat_ground(0.5 * n + kGroundMargin, 0.5));
  const BodyId last = hanging_links(scene, n, 0.5 * n + 2.0);
  for (Body& b : scene.bodies)
    if (b.id == last) b.linear_velocity = Vec3(2.0, 0.0, 0.0);
  return scene;
}

// Ten links of hanging_links and a box of 0.5 m and N kg (default 100) joined
// under the last (a mass ratio of N : 1 across that joint), at rest, the box
// pushed along +x at 1 m/s: it sways on the chain.
Scene make_heavy_chain(const SceneParams& params) {
  Scene scene;
  scene.name = "heavy-chain";
  scene.seed = params.seed;
  const int mass = magnitude_or_default(params, 100);
  constexpr int kLinks = 10;
  const double height = 0.5 * kLinks + 0.5 + 2.0;
  scene.bodies.push_back(flat_ground(0.5 * kLinks + kGroundMargin, 0.5));
  const BodyId last = hanging_links(scene, kLinks, height);
  const double bottom = height - 0.5 * kLinks;
  Body box = dynamic_box(last + 1, Vec3::Constant(0.25), mass, Vec3(0.0, bottom - 0.25, 0.0));
  box.linear_velocity = Vec3(1.0, 0.0, 0.0);
  scene.bodies.push_back(box);
  joint_at(scene, JointKind::PointToPoint, last, box.id, Vec3(0.0, bottom, 0.0));
  return scene;
}

// Two arms (boxes 1 x 0.1 x 0.1 m, 1 kg) hinged at one end about z to static
// posts 3 m up, 1 m apart along z, held out along +x, each driven by its
// hinge's motor (max impulse 1 N m s a step: at 1/60 s twelve times what
// holding the arm against gravity takes). The first hinge is free, its
// motor's target N rad/s (default 2): the arm turns round and round at that
// speed. The second is limited to [-pi/2, 0], its motor's target -1 rad/s:
// it lifts its arm to the vertical, the lower limit, and holds it there
// (Bullet's hinge angle, btHingeConstraint::getHingeAngle, is the rotation
// of body b's frame about frame a's z axis, clockwise positive).
Scene make_motor_hinge(const SceneParams& params) {
  Scene scene;
  scene.name = "motor-hinge";
  scene.seed = params.seed;
  const int speed = magnitude_or_default(params, 2);
  constexpr double kHeight = 3.0;
  scene.bodies.push_back(flat_ground(1.0 + kGroundMargin, 0.5));
  for (int k = 0; k < 2; ++k) {
    const double z = k;
    const BodyId post = static_cast<BodyId>(1 + 2 * k), arm = post + 1;
    scene.bodies.push_back(static_box(post, Vec3(0.05, 0.05, 0.05), Vec3(-0.1, kHeight, z)));
    scene.bodies.push_back(dynamic_box(arm, Vec3(0.5, 0.05, 0.05), 1.0, Vec3(0.5, kHeight, z)));
    Joint& hinge = joint_at(scene, JointKind::Hinge, post, arm, Vec3(0.0, kHeight, z));
    hinge.motor = true;
    hinge.motor_max_impulse = 1.0;
    hinge.motor_velocity = k == 0 ? speed : -1.0;
    if (k == 1) hinge.limited = true, hinge.lower = -kPi / 2, hinge.upper = 0.0;
  }
  return scene;
}

}  // namespace soda::detail
