// runtime/ — the step, threads, messages and the public API. This header is
// the one include for embedding SODA: a Simulation runs one scene on K
// Bullet worlds, one per territory, in the background (a thread per world, a
// pool, or one thread), each world publishing its bodies after every step to
// a transform buffer of its own; SceneReaders read the whole scene at a
// simulated time τ from those buffers. The result is bit-identical to one
// CanonicalWorld on the whole scene, whatever K, the partition, the threads
// or the readers. Guide: docs/embedding.md.
//
//   #include "soda/runtime/simulation.h"
//   soda::Scene scene = soda::make_scene("falling-cubes", {500, 1});
//   soda::Simulation sim(scene, {.territories = 4});
//   soda::SceneReader reader = sim.add_reader();
//   std::thread render([&] {                    // the render thread
//     for (int k = 0; k <= 300; ++k)
//       if (auto frame = reader.read_at(k / 60.0)) draw(frame->poses);
//   });
//   sim.start(5.0);                             // the worlds run freely up to 5 s
//   sim.advance_to(5.0);                        // wait until every world published 5 s
//   render.join();
//   sim.stop();                                 // idempotent; the destructor calls it
//   std::uint64_t h = sim.state_hash();         // == CanonicalWorld after 300 steps
//
// Thread safety: stated per member. In short: start, advance_to, run_for,
// stop, add_reader and the observers may be called from any thread; the
// readouts (state_hash, body_states, ...) wait for the worlds to be parked
// at their step limit or stopped; each SceneReader is used by one thread at
// a time. Errors: if a world fails (its thread throws), every waiting call —
// advance_to, run_for, a reader's wait, stop, the readouts — throws a
// SimulationError naming the world and the original message; nothing hangs
// and nothing exits silently.
#pragma once

#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

// What an embedder uses, and nothing more: the scene and its generators,
// the grid options and territory map of the config, the runtime knobs, the
// readers, queries, contact events and inputs, body states, snapshots and checkpoints. The
// partitioned runtime behind it (partitioned_world.h, territory_world.h, the
// policies) stays out; metrics() names WorldMetrics, declared here: include
// soda/runtime/world_metrics.h to read them.
#include "soda/grid/grid.h"
#include "soda/grid/territory_map.h"
#include "soda/runtime/checkpoint.h"
#include "soda/runtime/contact_reader.h"
#include "soda/runtime/runtime_options.h"
#include "soda/runtime/schedule.h"
#include "soda/runtime/scene_query.h"
#include "soda/runtime/scene_reader.h"
#include "soda/runtime/sensor_reader.h"
#include "soda/runtime/user_input.h"
#include "soda/scene/registry.h"
#include "soda/scene/scene.h"
#include "soda/worlds/body_state.h"
#include "soda/worlds/world_snapshot.h"

namespace soda::detail {
struct TestingHooks;  // internal (runtime/src/driver/testing_hooks.h)
}  // namespace soda::detail

namespace soda {

struct WorldMetrics;  // soda/runtime/world_metrics.h

struct SimulationConfig {
  int territories = 1;               // K worlds
  std::string partition = "kmeans";  // kmeans | rcb | grid:AxBxC | territory-map file (make_partition)
  GridOptions grid = {};             // cell size, origin, box of the partition
  int threads = 0;                   // 0 or >= K: a thread per world; 1: one thread for all
                                     // worlds (round-robin); 2 .. K-1: a pool of that many
  std::size_t buffer_capacity = 64;  // entries per world's transform buffer (>= 2): how far a
                                     // world may run ahead of the slowest reader, in steps
  /// Transform buffers store each step as the poses that changed since a
  /// shared key step (docs/transform-buffer.md, "Delta entries"): memory per
  /// buffered step follows the moving bodies. Readers get the same frames
  /// either way; false stores every pose of every step.
  bool delta_entries = true;
  bool serialise = false;            // every message between worlds through bytes
  /// Called by a world's thread after each of its scene steps (world id,
  /// scene step), before the step's entry is published. An exception thrown
  /// here fails that world, as a physics error would. Keep it short.
  std::function<void(WorldId, std::int64_t)> after_step = {};
  /// Accept input at steps some world has already passed (but not older
  /// than the commit horizon): every world keeps its state at each step
  /// boundary from the horizon to its clock (a snapshot per step) and such
  /// an input rolls every world back to its step. Every SceneReader holds
  /// the horizon at the frame it last used, so an input at the frame on
  /// screen is always accepted (docs/embedding.md, "The game loop"). Off:
  /// input only at steps no world has begun. Not with runtime.validate.
  bool past_inputs = false;
  /// Contact events (contact_reader.h, docs/contact-events.md): every world
  /// records after each scene step the contact points, normals and impulses
  /// of the pairs it reports, for ContactReaders and on_contacts. Off: no
  /// world records anything and the entries are as without events. Events
  /// never change the simulation: the same state_hash either way.
  bool contact_events = false;
  /// Needs contact_events. Called with the events of every final step from
  /// the run's first step on, in step order, once each, from one thread the
  /// Simulation starts for it (not a world's thread), while the worlds run
  /// on; stop() delivers every step final by then before it returns. It
  /// holds the worlds back like a reader (back-pressure) while it runs.
  /// Must not call stop() or a readout of this Simulation. An exception
  /// thrown here fails the run (SimulationError, world kNoWorld).
  std::function<void(const ContactStep&)> on_contacts = {};
  /// on_contacts also gets Persist events (a pair touching at this step and
  /// the one before).
  bool on_contacts_persist = false;
  /// The knobs every way of running a scene shares (runtime_options.h).
  /// Under a Simulation: with speculation (runtime.anticipation > 0) a lost
  /// bet republishes the entries of the rolled-back steps with a new
  /// revision (readers may see an entry, then a newer revision of its
  /// step); published_step(), advance_to() and the readouts count only
  /// committed steps (at or below the commit horizon), so they never return
  /// a state that can still change; with past_inputs an input at a past
  /// step is a rollback of every world to it (no hold), and every step is a
  /// checkpoint. The watchdog: off or stop (a WatchdogError is the cause of
  /// the SimulationError); heal is refused. Load balancing: only policy
  /// "none": a Simulation's worlds run freely and are never all stopped at
  /// one step, where a cession is applied (docs/loadbalance.md).
  RuntimeOptions runtime = {};
  /// Knobs only tests set (the fuzzer's pauses, ...), as
  /// PartitionedOptions::testing. Leave empty.
  std::shared_ptr<const detail::TestingHooks> testing = {};
};

/// A world failed. world(): the world whose thread threw (kNoWorld if no
/// single world is to blame, e.g. a deadlock report of the one-thread
/// schedule); message(): the original exception's what(); cause(): the
/// original exception (PartitionError, ValidationError, MessageFormatError,
/// whatever after_step threw, ...).
class SimulationError : public std::runtime_error {
 public:
  SimulationError(WorldId world, const std::string& message, std::exception_ptr cause);
  WorldId world() const noexcept { return world_; }
  const std::string& message() const noexcept { return message_; }
  std::exception_ptr cause() const noexcept { return cause_; }

 private:
  WorldId world_;
  std::string message_;
  std::exception_ptr cause_;
};

/// A Simulation's whole state at one scene step boundary
/// (Simulation::snapshot()), from which a Simulation goes on exactly as the
/// one it was taken from — with any territories, partition, threads or
/// speculation (docs/embedding.md, "Snapshots"). Plain values, copyable;
/// the bodies' states and contacts in btScalar bits (a snapshot of the float
/// build is not one of the double build).
struct SimulationSnapshot {
  /// Every body, statics included, and every contact, at scene step
  /// state.steps_done.
  WorldSnapshot state;
  /// The inputs given for steps at or after that step (not applied yet), in
  /// the order they apply.
  std::vector<UserInput> inputs;
  /// Ids of bodies and of joints removed before that step: a restored run never reuses them.
  std::vector<BodyId> retired_ids;
  std::vector<JointId> retired_joint_ids;
};

class SimulationEngine;  // internal

/// One scene on K worlds in the background, read through SceneReaders; see
/// the example at the top of this header and docs/embedding.md. Lifecycle:
/// constructed (step 0 published, no thread) -> running up to a step limit
/// (start, advance_to, run_for raise it; worlds park at it) -> stopped.
class Simulation {
 public:
  /// Cuts the scene into config.territories territories (config.partition,
  /// config.grid), builds one world per territory and publishes step 0 (the
  /// scene as given, time 0). No thread runs yet. Throws SceneError (naming
  /// the body or joint and field) for a scene no scene file could hold,
  /// std::invalid_argument for a bad config, GridError for a bad partition,
  /// PartitionError for a scene outside the partitioned step's contract.
  explicit Simulation(const Scene& scene, SimulationConfig config = {});
  /// As above with a ready territory map (config.territories, partition and grid are ignored).
  Simulation(const Scene& scene, TerritoryMap map, SimulationConfig config = {});
  /// Restores a snapshot (Simulation::snapshot()): a Simulation at scene step
  /// snapshot.state.steps_done, published as its first frame, steps numbered
  /// on from it, that goes on exactly as the run the snapshot was taken from
  /// (the same frames and state_hash at every later step), cut into
  /// config.territories territories of the bodies where they are now. The
  /// snapshot's inputs are queued. Throws as the scene constructor, and
  /// std::invalid_argument for a snapshot whose inputs do not hold.
  explicit Simulation(const SimulationSnapshot& snapshot, SimulationConfig config = {});
  /// As above with a ready territory map.
  Simulation(const SimulationSnapshot& snapshot, TerritoryMap map, SimulationConfig config = {});
  /// Resumes a checkpoint file written by save(): Simulation(read_checkpoint(path),
  /// config), a Simulation at the saved step that goes on bit for bit as the
  /// run that saved it, with any territories, partition, threads and
  /// speculation (docs/checkpoints.md). Throws CheckpointError naming the
  /// file for one that is unreadable, truncated, damaged, of another version
  /// or of another precision; otherwise as the snapshot constructor.
  ///   soda::Simulation sim = soda::Simulation::resume("at-5s.ckpt", {.territories = 8});
  static Simulation resume(const std::string& path, SimulationConfig config = {});
  /// stop(); a SimulationError is swallowed here (logged).
  ~Simulation();
  Simulation(const Simulation&) = delete;
  Simulation& operator=(const Simulation&) = delete;

  // --- running -------------------------------------------------------------

  /// Lets the worlds run freely in the background, without waiting for
  /// anyone but their neighbours and the readers' back-pressure, up to
  /// `end_time` (the step at or before it), or until stop() when there is
  /// none. Raises the step limit only, never lowers it (advance_to raises it
  /// too). Throws std::logic_error after stop(), SimulationError if a world
  /// has failed. Any thread; never waits.
  void start(std::optional<double> end_time = std::nullopt);

  /// Waits until every world has published the step at or before `time`,
  /// first raising the step limit to it if it is lower (so without start()
  /// the worlds run exactly to `time` and park there). True once published;
  /// false if stop() was called first (from another thread); throws
  /// SimulationError if a world failed, std::invalid_argument for a negative
  /// or NaN time. Readers that are never read stall it once the buffers are
  /// full: read them on other threads. Any thread.
  bool advance_to(double time);

  /// advance_to(published_time() + seconds): `seconds` of simulated time
  /// beyond what every world has published now. Any thread.
  bool run_for(double seconds);

  /// Stops the worlds at one step boundary — the highest step any of them
  /// had begun, which the others complete — releases every waiter (blocked
  /// readers return what is held or nullopt; writers waiting for room drop
  /// their entries) and joins the threads. Idempotent; irreversible. Throws
  /// the SimulationError if a world failed (every time it is called). Any
  /// thread; returns after at most one more step of the slowest world.
  void stop();

  // --- input (any thread; docs/embedding.md, "Input") ------------------------
  //
  // Each call applies at the boundary after the scene step at or before
  // `time` (step_at(time)), before the next step begins, in call order among
  // inputs of one step; the result is the same whenever the call is made.
  // An input at a step no world has begun is queued. One at a step some
  // world has passed needs config.past_inputs: every world is held at one
  // boundary, rolled back to the input's step and runs again (entries of
  // later steps are republished with a new revision); with speculation
  // (config.runtime.anticipation) it is posted as a rollback of every world that
  // each takes on its own thread, nobody held. An input older than
  // the commit horizon (commit_horizon_step()) is refused. Errors:
  // std::invalid_argument naming the body and the step (unknown or reused
  // id, a body not present at that step or static, a bad body, a value out
  // of range: the message names the field, a step too old or past steps
  // without past_inputs); nothing of a refused input is applied, SimulationError if a world failed,
  // std::logic_error after stop().

  /// Adds a dynamic body; body.id must be an id never used in this run.
  /// Returns it.
  BodyId add_body(double time, const Body& body);
  /// Removes a dynamic body, with its contacts.
  void remove_body(double time, BodyId id);
  /// Sets a dynamic body's velocities and wakes it.
  void set_velocity(double time, BodyId id, const Vec3& linear, const Vec3& angular = Vec3::Zero());
  /// Gives a dynamic body an impulse (N s) at its centre and wakes it.
  void apply_impulse(double time, BodyId id, const Vec3& impulse);
  /// Sets the scene's gravity (m/s^2) from the next step on, in every world
  /// at the same step: awake bodies feel it at once, sleepers when they
  /// wake (it wakes nobody). Snapshots and checkpoints carry it. A stronger
  /// gravity than the scene's may take bodies beyond the run's reach
  /// (SimulationConfig::runtime's reach speed): that fails the run with a
  /// PartitionError naming the body, as any too fast body does. Refused:
  /// a non-finite vector.
  void set_gravity(double time, const Vec3& gravity);
  /// Sets a dynamic body's mass (kg; > 0 and finite), its inertia following
  /// from its shape, from the next step on. Does not wake it.
  void set_mass(double time, BodyId id, double mass);
  /// Sets a dynamic body's friction coefficient (>= 0 and finite): contacts
  /// take it at their next narrowphase. Does not wake it.
  void set_friction(double time, BodyId id, double friction);
  /// Sets a dynamic body's restitution coefficient (in [0, 1]), as
  /// set_friction.
  void set_restitution(double time, BodyId id, double restitution);
  /// Sets a dynamic body's user data (Body::user_data): frames from the next
  /// step on read it (SceneReader::body_at); no physics reads it.
  void set_user_data(double time, BodyId id, std::uint64_t user_data);
  /// Sets a dynamic or kinematic body's collision filter (Body::collision_group, collision_mask; a kinematic
  /// body's: Body::filter_commands) from the next step on: its contacts end there and begin again where the
  /// filter passes, alike for every K (docs/embedding.md, "Setters and readbacks"). Does not wake it.
  void set_collision_filter(double time, BodyId id, std::uint32_t group, std::uint32_t mask);
  /// Moves a kinematic body (Body::kinematic) to `pose` over the next step:
  /// it reaches the pose at the end of that step, its velocity from the move
  /// (so that what it touches is pushed and carried), in every world at the
  /// same step. The first such input (or set_pose) ends the body's path;
  /// from then on it holds the pose it last reached (docs/scene-format.md,
  /// "Kinematic bodies"). Refused, naming the body and field: an id that is
  /// not a kinematic body, a non-finite position, a zero or non-finite
  /// orientation.
  void set_kinematic_target(double time, BodyId id, const Pose& pose);
  /// Puts a body at `pose` at once (a teleport). A kinematic body: there
  /// from the next internal step on, with zero velocity for that move (it
  /// pushes nothing on the way), then holding it. A dynamic body: its owner
  /// moves it there at the step's boundary, keeping its velocities, and wakes
  /// it; its contacts refresh at the next narrowphase (a pair whose bodies
  /// are apart loses its points). In a partitioned run the new pose must be
  /// within the run's reach of the old one (a neighbour's cells), else the run
  /// fails with a PartitionError naming the body, as a too fast body does.
  /// Refused: a static body, a non-finite position, a zero or non-finite
  /// orientation.
  void set_pose(double time, BodyId id, const Pose& pose);
  /// Removes a joint (Scene::joints, by Joint::id), broken or not, and wakes
  /// the dynamic bodies it joined: what is left of its joint group falls
  /// apart into the groups its other joints connect, as when a body is
  /// removed (docs/partitioned-step.md, "Joints"). Refused, naming the
  /// joint: an id no joint has at that step (never in the scene, removed
  /// before, or gone with a body removed at or before the step); a joint
  /// removed twice. A body of a joint with a removal queued cannot be
  /// removed at an earlier step (remove the joint first).
  void remove_joint(double time, JointId id);
  /// Adds a joint (a scene file's joint: docs/scene-format.md, "Joints")
  /// from that step on and wakes its dynamic bodies. It is held by the one
  /// world that owns its dynamic bodies, so only a joint that joins no two
  /// joint groups is taken (docs/embedding.md, "Joints"): a body pinned to
  /// a static one, two bodies of one joint group at that step (a loop
  /// closed), or bodies all added at that step (a group spawned: the world
  /// of its anchor's home cell takes it whole). Refused, naming the joint
  /// and the field: a joint joining two groups or free bodies otherwise;
  /// an id a joint has or had (in the scene or by an
  /// input); a body not in the scene at that step; two static bodies, a
  /// kinematic body, bad frames or limits (the scene file's rules). A body
  /// removal or a joint removal at an earlier step that would split the
  /// group such an addition closes a loop in is refused in turn.
  void add_joint(double time, const Joint& joint);
  /// Sets a joint's motor from the next step on and wakes the dynamic bodies
  /// it joins: on or off, its target velocity (rad/s about a hinge's or an
  /// angular axis, m/s along a slider's or a linear axis) and its max
  /// impulse (a hinge: N m s a step; a slider: Bullet's max linear motor
  /// force) or, for a 6-DoF spring joint, the max force of `axis` (0..5: x,
  /// y, z linear, then x, y, z angular; off stores max force 0). The joint's
  /// description changes (Joint::motor, motor_velocity, motor_max_impulse;
  /// motor_velocities, motor_max_forces) and its constraint is the one the
  /// new description makes; snapshots and checkpoints carry it. Refused,
  /// naming the joint and the field: an id no joint has at that step (as
  /// remove_joint), a point-to-point, cone-twist or fixed joint (no motor),
  /// an axis given for a hinge or slider or none (-1) or out of 0..5 for a
  /// 6-DoF spring joint, a non-finite velocity, a negative or non-finite
  /// max impulse. A joint with a motor input queued cannot be removed at an
  /// earlier step, nor its bodies.
  void set_joint_motor(double time, JointId id, bool on, double velocity, double max_impulse, int axis = -1);
  /// The call for `input`'s kind at time_of(input.step): an input record
  /// as an input file or input_log() holds it (user_input.h), given as the
  /// calls above give it, with their errors. Returns the body's id.
  BodyId give(const UserInput& input);
  /// The commit horizon (GVT): the oldest scene step an input may still
  /// name (with past_inputs), the newest step every world has reached
  /// without it. Never decreases.
  std::int64_t commit_horizon_step() const;
  /// Rollbacks done for inputs at past steps.
  std::uint64_t rollbacks() const;
  /// Every input this Simulation's input calls accepted (not those a
  /// snapshot it was restored from queued), sorted by step, calls of one
  /// step in call order: the order they apply in. Any thread.
  std::vector<UserInput> input_log() const;
  /// Writes input_log() to `path` as an input file (docs/inputs.md): `soda
  /// run --inputs PATH` on the same scene replays the run to the same hash
  /// (`--resume CHECKPOINT --inputs PATH` for a Simulation restored from
  /// one). Throws std::runtime_error naming the path if it cannot be
  /// written. Any thread; the inputs accepted so far.
  void write_input_log(const std::string& path) const;

  // --- readers -------------------------------------------------------------

  /// A new reader with a cursor in every world's buffer; it pins every held
  /// entry until its first read. Any thread.
  SceneReader add_reader();
  /// A reader of contact events per committed step (contact_reader.h);
  /// `persist`: also report pairs that stay in contact. Throws
  /// std::logic_error unless config.contact_events. Any thread.
  ContactReader add_contact_reader(bool persist = false);
  /// Queries at a time — ray casts, sweeps, overlaps — answered from the
  /// committed frame of its step (scene_query.h); a reader of its own inside,
  /// which never holds the commit horizon (with past_inputs an add_reader()
  /// reader does), so one thread may read a frame and query it. Any thread.
  SceneQuery add_query();
  /// A reader of sensor events per committed step (sensor_reader.h): the
  /// bodies each sensor (Body::sensor) overlaps, begin and end. Any thread.
  SensorReader add_sensor_reader();

  // --- observers (any thread, never wait; a snapshot) ----------------------

  double dt() const;
  /// The scene step at or before `time` (to within 1e-9 of a step, a time
  /// computed as k * dt or k / rate counts as step k). Throws
  /// std::invalid_argument for a negative or NaN time.
  std::int64_t step_at(double time) const;
  /// step * dt: the time an entry of `step` carries.
  double time_of(std::int64_t step) const;
  /// The newest scene step every world has published (0 at construction, a
  /// snapshot's step when restored); with speculation, published and
  /// committed by the worlds' own speculation (readers' holds left out). An
  /// input at a past step takes it back to that step.
  std::int64_t published_step() const;
  double published_time() const { return time_of(published_step()); }
  /// Per world, the newest scene step it has published: how far each runs
  /// ahead of the others.
  std::vector<std::int64_t> published_steps() const;
  bool stopped() const;
  /// The error that failed the run, if any.
  std::optional<SimulationError> error() const;
  int world_count() const;
  Schedule schedule() const;
  int thread_count() const;  // threads that step the worlds
  /// Per world, what its transform buffer's held entries take now
  /// (TransformBuffer::memory()). Any thread; a snapshot.
  std::vector<BufferMemory> buffer_memory() const;

  // --- readouts: wait until every world is parked at the step limit, or
  //     stopped; throw std::logic_error while the worlds run without limit
  //     (start() without end time; stop() first), SimulationError after a
  //     failure. Any thread, but not concurrently with a call that raises
  //     the limit. -----------------------------------------------------------

  /// Scene steps every world has done.
  std::int64_t steps_done() const;
  /// Raw states of every body, statics included, sorted by id.
  std::vector<BodyState> body_states() const;
  /// soda::state_hash(body_states()): equal to CanonicalWorld::state_hash()
  /// after steps_done() steps.
  std::uint64_t state_hash() const;
  /// The whole state at steps_done(): bodies, contacts and the inputs still
  /// to apply. A Simulation constructed from it goes on exactly as this one
  /// (docs/embedding.md, "Snapshots"). Cost: O(bodies + contacts), copied
  /// while the worlds are parked.
  SimulationSnapshot snapshot() const;
  /// Writes snapshot() to a checkpoint file at `path` (docs/checkpoints.md;
  /// written to `path`.tmp and renamed, never half a file) and returns its
  /// step, steps_done(): the committed step the worlds are parked at.
  /// Simulation::resume(path, config) goes on from it. Throws
  /// CheckpointError if the file cannot be written.
  std::int64_t save(const std::string& path) const;
  std::size_t sleeping_count() const;
  std::size_t body_count() const;
  std::vector<WorldMetrics> metrics() const;

 private:
  std::unique_ptr<SimulationEngine> engine_;
};

}  // namespace soda
