// Joints driven by the player (docs/embedding.md, "Joints"): a castle yard
// built in code on 2 territories that speculate (anticipation 8). A
// drawbridge hinged to its gate post is raised by its hinge's motor at 1 s,
// lowered at 2.5 s and let go at 4 s, to fall back onto its support; a
// crate hangs on a rope of eight links from a beam, and the player cuts the
// rope at 2 s (remove_joint); a door stands loose in its jamb until the
// player hangs it on a hinge at 0.1 s (add_joint, the frames computed from
// the pose the frame on screen shows), then kicks it open at 3 s. A render
// thread reads every frame while the worlds run ahead of it and gives each
// call at the frame on screen, a step the worlds have already passed: they
// roll back and re-run with it. The run ends on the hash of one world given
// the same calls before it ran (exit 1 if not).
// Usage: drawbridge [SECONDS]   (default 5 s)
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <functional>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "soda/runtime/simulation.h"

namespace {

// Ids of the yard's bodies and joints.
constexpr soda::BodyId kGround = 1, kBeam = 2, kFirstLink = 3, kCrate = 11, kPost = 12, kBridge = 13,
                       kSupport = 14, kJamb = 15, kDoor = 16;
constexpr int kLinks = 8;
constexpr soda::JointId kBridgeHinge = 0, kCutJoint = 4, kDoorHinge = 20;
constexpr double kLink = 0.5;  // m, pivot to pivot

soda::Body box(soda::BodyId id, const soda::Vec3& half, double mass, const soda::Vec3& at) {
  soda::Body b;
  b.id = id;
  b.is_static = mass == 0;
  b.mass = mass == 0 ? 1.0 : mass;
  b.shape = soda::Shape::box(half);
  b.position = at;
  return b;
}

const soda::Body& body(const soda::Scene& s, soda::BodyId id) {
  for (const soda::Body& b : s.bodies)
    if (b.id == id) return b;
  throw std::logic_error("no body " + std::to_string(id));
}

// A joint whose frames meet at `pivot` (world), turned by `turn`, given the
// two bodies' poses.
soda::Joint joint_at(soda::JointId id, soda::JointKind kind, soda::BodyId a, const soda::Vec3& a_at,
                     const soda::Quat& a_turn, soda::BodyId b, const soda::Vec3& b_at, const soda::Quat& b_turn,
                     const soda::Vec3& pivot, const soda::Quat& turn = soda::Quat::Identity()) {
  soda::Joint j;
  j.id = id;
  j.kind = kind;
  j.body_a = a, j.body_b = b;
  j.frame_a = {a_turn.conjugate() * (pivot - a_at), a_turn.conjugate() * turn};
  j.frame_b = {b_turn.conjugate() * (pivot - b_at), b_turn.conjugate() * turn};
  return j;
}

soda::Joint joint_at(const soda::Scene& s, soda::JointId id, soda::JointKind kind, soda::BodyId a, soda::BodyId b,
                     const soda::Vec3& pivot) {
  const soda::Body &ba = body(s, a), &bb = body(s, b);
  return joint_at(id, kind, a, ba.position, ba.orientation, b, bb.position, bb.orientation, pivot);
}

soda::Scene castle_yard() {
  soda::Scene s;
  s.name = "castle-yard";
  s.bodies.push_back(box(kGround, {14, 0.5, 4}, 0, {0, -0.5, 0}));
  // The rope: a beam 6 m up, eight 1 kg links, a 20 kg crate (x = -6).
  s.bodies.push_back(box(kBeam, {0.5, 0.1, 0.5}, 0, {-6, 6.1, 0}));
  for (int i = 0; i < kLinks; ++i)
    s.bodies.push_back(box(kFirstLink + i, {0.05, 0.5 * kLink, 0.05}, 1, {-6, 6 - kLink * (i + 0.5), 0}));
  s.bodies.push_back(box(kCrate, {0.3, 0.3, 0.3}, 20, {-6, 6 - kLink * kLinks - 0.3, 0}));
  for (int i = 0; i <= kLinks; ++i)
    s.joints.push_back(joint_at(s, static_cast<soda::JointId>(1 + i), soda::JointKind::PointToPoint,
                                i == 0 ? kBeam : kFirstLink + i - 1, i == kLinks ? kCrate : kFirstLink + i,
                                {-6, 6 - kLink * i, 0}));
  // The drawbridge: a 4 m, 40 kg plank from the gate post's top to a
  // support, hinged at the post about z; its motor is off until driven.
  s.bodies.push_back(box(kPost, {0.25, 1, 1.5}, 0, {0.75, 1, 0}));
  s.bodies.push_back(box(kBridge, {2, 0.1, 1.2}, 40, {3.0, 2.1, 0}));
  s.bodies.push_back(box(kSupport, {0.25, 1, 1.5}, 0, {4.9, 1, 0}));  // under the far end
  s.joints.push_back(joint_at(s, kBridgeHinge, soda::JointKind::Hinge, kPost, kBridge, {1.0, 2.1, 0}));
  // The door: a jamb, and a 15 kg panel standing in it, held by nothing yet.
  s.bodies.push_back(box(kJamb, {0.1, 1.5, 0.1}, 0, {8, 1.5, -1}));
  s.bodies.push_back(box(kDoor, {0.05, 1.4, 0.5}, 15, {8, 1.401, -0.4}));
  return s;
}

// What the player does, as calls that can be given again to another
// Simulation (the one-world reference).
using Call = std::function<void(soda::Simulation&)>;

// The door's hinge from the door's pose on screen: about y, at the jamb's
// edge.
soda::Joint door_hinge(const soda::Scene& s, const soda::ScenePose& door) {
  const soda::Body& jamb = body(s, kJamb);
  const soda::Vec3 at(door.position[0], door.position[1], door.position[2]);
  const soda::Quat turn(door.orientation[3], door.orientation[0], door.orientation[1], door.orientation[2]);
  const soda::Quat about_y(Eigen::AngleAxisd(-std::numbers::pi / 2, soda::Vec3::UnitX()));  // the hinge's z axis along y
  return joint_at(kDoorHinge, soda::JointKind::Hinge, kJamb, jamb.position, jamb.orientation, kDoor, at, turn,
                  {8, 1.401, -0.9}, about_y);
}

// The bridge's hinge motor: turn at `speed` rad/s (Bullet's hinge angle: body
// b's frame about frame a's z, clockwise positive, so a negative speed lifts
// the plank's far end), with at most kWinchImpulse N m s a step; speed 0
// holds the bridge where it is.
constexpr double kWinchImpulse = 40.0;  // the plank's weight takes 785 N m: 13 N m s a step

void drive(soda::Simulation& sim, double t, soda::JointId hinge, double speed) {
  sim.set_joint_motor(t, hinge, true, speed, kWinchImpulse);
}

void release(soda::Simulation& sim, double t, soda::JointId hinge) {  // the motor off: the bridge falls free
  sim.set_joint_motor(t, hinge, false, 0.0, 0.0);
}

// The calls of frame k; `frame` is what is on screen.
std::vector<Call> play(const soda::Scene& s, int k, const soda::SceneFrame& frame) {
  std::vector<Call> calls;
  const double t = k / 60.0;
  if (k == 6) {  // hang the door where it stands now
    const soda::Joint hinge = door_hinge(s, *frame.find(kDoor));
    calls.push_back([=](soda::Simulation& sim) { sim.add_joint(t, hinge); });
  }
  if (k == 60) calls.push_back([=](soda::Simulation& sim) { drive(sim, t, kBridgeHinge, -1.0); });    // raise
  if (k == 150) calls.push_back([=](soda::Simulation& sim) { drive(sim, t, kBridgeHinge, 0.6); });     // lower
  if (k == 240) calls.push_back([=](soda::Simulation& sim) { release(sim, t, kBridgeHinge); });       // let go
  if (k == 120) calls.push_back([=](soda::Simulation& sim) { sim.remove_joint(t, kCutJoint); });      // cut
  if (k == 180)                                                                                       // kick
    calls.push_back([=](soda::Simulation& sim) { sim.apply_impulse(t, kDoor, soda::Vec3(30, 0, 0)); });
  return calls;
}

double angle_of(const soda::ScenePose& p) {  // about z, of the plank's x axis
  const soda::Quat q(p.orientation[3], p.orientation[0], p.orientation[1], p.orientation[2]);
  const soda::Vec3 x = q * soda::Vec3::UnitX();
  return std::atan2(x[1], x[0]);
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const double seconds = argc > 1 ? std::atof(argv[1]) : 5.0;
    if (!(seconds > 0)) {
      std::fprintf(stderr, "usage: drawbridge [SECONDS > 0]\n");
      return 2;
    }
    const soda::Scene scene = castle_yard();
    const int frames = static_cast<int>(seconds * 60.0);
    soda::SimulationConfig config{.territories = 2, .partition = "grid:2x1x1", .buffer_capacity = 32,
                                  .past_inputs = true};
    config.runtime.anticipation = 8;
    soda::Simulation sim(scene, config);
    soda::SceneReader reader = sim.add_reader();  // before start: it sees frame 0
    sim.start(sim.time_of(frames));

    // The render thread: draws each frame (here: prints the yard twice a
    // second) and gives the player's calls at the frame on screen.
    std::vector<Call> given;
    std::exception_ptr render_error;
    std::thread render([&] {
      try {
        for (int k = 0; k <= frames; ++k) {
          const std::optional<soda::SceneFrame> frame = reader.read_at(sim.time_of(k));
          if (!frame) break;  // the run was stopped
          for (Call& c : play(scene, k, *frame)) {
            c(sim);
            given.push_back(std::move(c));
          }
          if (k % 30 != 0) continue;
          const soda::ScenePose& door = *frame->find(kDoor);
          const soda::Quat turn(door.orientation[3], door.orientation[0], door.orientation[1], door.orientation[2]);
          const soda::Vec3 across = turn * soda::Vec3::UnitZ();  // the door's width, jamb to free edge
          std::printf("t = %4.2f s: crate %5.2f m up, bridge raised %5.1f deg, door open %5.1f deg\n", frame->time,
                      double(frame->find(kCrate)->position[1]), angle_of(*frame->find(kBridge)) * 180 / std::numbers::pi,
                      std::atan2(across[0], across[2]) * 180 / std::numbers::pi);
        }
      } catch (...) {
        render_error = std::current_exception();
      }
    });
    render.join();
    if (render_error) std::rethrow_exception(render_error);
    sim.advance_to(sim.time_of(frames));
    const std::uint64_t hash = sim.state_hash();
    std::printf("%d frames, %llu rollbacks (the calls at the frame on screen)\n", frames,
                static_cast<unsigned long long>(sim.rollbacks()));
    sim.stop();

    // One world, the same calls given before it runs.
    soda::Simulation one(scene, {.threads = 1});
    for (const Call& c : given) c(one);
    one.advance_to(one.time_of(frames));
    const std::uint64_t expected = one.state_hash();
    std::printf("state hash %016llx, one world %016llx: %s\n", static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(expected), hash == expected ? "equal" : "DIFFERENT");
    return hash == expected ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "drawbridge: %s\n", e.what());
    return 1;
  }
}
