// runtime/ — the public embedding API. This header: reading the whole
// scene's state at a time τ from every world's transform buffer (the
// thesis' render thread). Include soda/runtime/simulation.h, which brings it.
//
// Every world publishes, after each scene step t, an entry (t, t * dt) with
// the poses of the bodies it owns at that step boundary. A SceneReader joins
// the K entries of one step into a SceneFrame; since migrants are absorbed
// within the step that sends them, every body alive at that step is in
// exactly one world's entry (checked on every read against the bodies the
// scene and the inputs give that step: a body twice, missing or not alive
// throws). A reader serves final frames only: frames no rollback can change
// (with speculation or past inputs, once the commit horizon has reached
// them); with past inputs it holds the horizon at the frame it uses, so an
// input at the frame on screen is accepted (docs/embedding.md, "The game
// loop").
//
//   soda::SceneReader reader = sim.add_reader();       // any thread
//   std::thread render([&] {
//     for (int k = 0; k <= 300; ++k)                     // 60 Hz of simulated time
//       if (auto frame = reader.read_at(k / 60.0))       // waits for every world
//         draw(frame->poses);                            // every body once, by id
//   });
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/rollback/transform_buffer.h"
#include "soda/rollback/transform_entry.h"
#include "soda/worlds/body_state.h"

namespace soda {

/// Pose and velocities of one body, in the precision Bullet was built with.
using ScenePose = BodyPose<btScalar>;
/// Poses interpolated between two frames (transform_entry.h).
using SceneSample = PoseSample<btScalar>;

/// A body's pose from its raw state: the position is the origin, the
/// orientation btMatrix3x3::getRotation of the basis, the velocities as they
/// are, sleeping when the activation state is Bullet's ISLAND_SLEEPING. A pure function: a frame equals, bit for bit, body_pose() of the
/// one-world CanonicalWorld's body_states() at the same step.
ScenePose body_pose(const BodyState& state);

/// The whole scene at one step boundary.
struct SceneFrame {
  std::int64_t step = 0;         // scene step
  double time = 0.0;             // step * dt, seconds
  std::vector<ScenePose> poses;  // every dynamic body alive at `step` exactly once, ascending id
  /// owners[i]: the world whose entry held poses[i] (its owner at `step`).
  std::vector<WorldId> owners;
  /// Per world: thread CPU time it spent since its previous entry
  /// (TransformEntry::busy_seconds), seconds; 0 for step 0.
  std::vector<double> busy_seconds;
  /// Every kinematic body (docs/scene-format.md, "Kinematic bodies") at
  /// `step`, ascending id: where every world has it then (its path, then the
  /// set_kinematic_target and set_pose inputs at boundaries before `step`),
  /// with the velocity of its last internal step's move; sleeping when that
  /// move was none. Not in `poses`, `owners` or the census check.
  std::vector<ScenePose> kinematic;
  /// The pose of `id`, or null if it is not a dynamic body of the scene at
  /// this step.
  const ScenePose* find(BodyId id) const;
  /// The pose of kinematic body `id`, or null if it is not one.
  const ScenePose* find_kinematic(BodyId id) const;
};

/// What an application reads back of one body at one committed step
/// (SceneReader::body_at): its pose and velocities from the frame, the
/// world that owned it, and the properties inputs gave it. The same for
/// any number of territories.
struct BodyAt {
  std::int64_t step = 0;     // the frame's scene step
  double time = 0.0;         // step * dt, seconds
  ScenePose pose;            // as SceneFrame::find (or find_kinematic) gives it, bit for bit
  WorldId owner = kNoWorld;  // the world whose entry held it; kNoWorld for a kinematic body (every world holds it)
  double mass = 0.0;         // kg, as the scene or set_mass gave it before `step`
  double friction = 0.0;     // as the scene or set_friction gave it before `step`
  double restitution = 0.0;  // as the scene or set_restitution gave it before `step`
  std::uint64_t user_data = 0;  // Body::user_data, as set_user_data gave it before `step`
  std::uint32_t collision_group = kDefaultCollisionGroup;  // as the scene or set_collision_filter gave it before `step`
  std::uint32_t collision_mask = kAllCollisionGroups;      // the same
};

struct SimulationCore;  // internal, shared by a Simulation and its readers

/// A cursor into every world's transform buffer (one reader per buffer),
/// made by Simulation::add_reader(). Entries are freed at the minimum of the
/// readers' cursors and the commit step, so a reader that does not read
/// holds the worlds back once their buffers are full (back-pressure: it
/// slows the run down, nothing more). Destroy a reader you no longer read.
///
/// Reads go forward: a read at τ moves the cursor of every world to its
/// newest entry at or before τ, freeing what lies behind it; a later read at
/// an earlier τ finds it freed (nullopt), except the frame it last read,
/// which stays readable.
///
/// Thread safety: one thread at a time per reader (each reader may live on a
/// thread of its own, e.g. a render thread); readers and the Simulation's
/// calls may run concurrently. A reader may outlive its Simulation: reads
/// then serve what is still held, and never wait.
class SceneReader {
 public:
  SceneReader(SceneReader&&) noexcept;
  SceneReader& operator=(SceneReader&&) noexcept;
  SceneReader(const SceneReader&) = delete;
  SceneReader& operator=(const SceneReader&) = delete;
  /// Unregisters from every buffer (its pins go). Any thread but the one
  /// reading with it.
  ~SceneReader();

  /// The scene at the closest step at or before `time` (s >= 0): waits until
  /// every world has published that step and it is final. With past inputs
  /// the reader holds the commit horizon there from now on (an input at this
  /// frame's time is still accepted) and releases what it held before.
  /// nullopt if the step is no longer
  /// held (the reader moved past it), or the Simulation was stopped before
  /// every world published it. Throws SimulationError if a world failed
  /// while it waited, std::invalid_argument for a negative or NaN time,
  /// std::logic_error if the worlds' entries do not hold every body alive at
  /// that step exactly once. Reader's thread.
  std::optional<SceneFrame> read_at(double time);

  /// As read_at, but never waits: nullopt also when some world has not
  /// published the step yet (keep the previous frame). Reader's thread.
  std::optional<SceneFrame> try_read_at(double time);

  /// Poses at `time` interpolated between the frame at or before it and the
  /// next one (interpolate_entries: positions and velocities linear,
  /// orientations slerped); waits for both. At a step's own time the poses
  /// are that frame's, bit for bit. If the run stops before the next frame
  /// exists, the earlier frame's poses (no extrapolation). With past inputs
  /// it holds the horizon at the later frame (give inputs at its time).
  /// nullopt and errors as read_at. Reader's thread.
  std::optional<SceneSample> interpolate(double time);

  /// One body at the closest step at or before `time`: read_at(time) (it
  /// waits, moves the cursor and holds the horizon as read_at does) and
  /// that body of the frame, with its properties at that step. nullopt as
  /// read_at, and when `id` is neither a dynamic body of the scene at that
  /// step nor a kinematic body. Costs a frame's assembly (O(bodies)): to read many bodies of one
  /// step, read the frame and call properties(). Reader's thread.
  ///   if (auto b = reader.body_at(2.0, 17)) aim_at(b->pose.position, b->user_data);
  std::optional<BodyAt> body_at(double time, BodyId id);
  /// As body_at, but never waits (try_read_at). Reader's thread.
  std::optional<BodyAt> try_body_at(double time, BodyId id);
  /// The mass, friction, restitution and user data body `id` has in the
  /// frame of `step` (inputs at boundaries before `step`), in a BodyAt
  /// whose step is `step` and pose and owner are left default; nullopt for an id the
  /// run never had. Exact for any step the frame exists; never waits. Any
  /// thread.
  std::optional<BodyAt> properties(std::int64_t step, BodyId id) const;

  /// Step of the last frame this reader returned; -1 before its first read.
  /// Reader's thread.
  std::int64_t last_step() const { return last_step_; }

 private:
  friend class Simulation;
  enum class Got { Frame, NotYet, Gone };
  // pins: hold the commit horizon at the frame in use (with past inputs,
  // docs/embedding.md, "Final frames"); a query's reader does not.
  SceneReader(std::shared_ptr<SimulationCore> core, bool pins);
  Got gather(std::int64_t step, bool move_cursors, std::vector<std::shared_ptr<const TransformEntry<btScalar>>>& out);
  SceneFrame assemble(std::int64_t step, const std::vector<std::shared_ptr<const TransformEntry<btScalar>>>& entries) const;
  std::optional<SceneFrame> read(double time, bool wait);
  void use_up_to(std::int64_t step);
  void release() noexcept;

  std::shared_ptr<SimulationCore> core_;
  std::vector<BufferReaderId> ids_;  // one per world
  std::int64_t last_step_ = -1;
  std::int64_t pinned_ = -1;  // the step this reader holds the commit horizon at; -1: none
};

}  // namespace soda
