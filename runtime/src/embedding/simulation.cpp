// Simulation: the public face of SimulationEngine (simulation_engine.h).
#include "soda/runtime/simulation.h"

#include <algorithm>
#include <cmath>
#include <fstream>

#include "embedding/simulation_engine.h"
#include "soda/grid/partition.h"
#include "soda/scene/validate.h"

namespace soda {

SimulationError::SimulationError(WorldId world, const std::string& message, std::exception_ptr cause)
    : std::runtime_error(world == kNoWorld ? "simulation failed: " + message
                                          : "world " + std::to_string(world) + " failed: " + message),
      world_(world),
      message_(message),
      cause_(std::move(cause)) {}

namespace {

TerritoryMap partition_for(const Scene& scene, const SimulationConfig& config) {
  if (config.territories < 1) throw std::invalid_argument("SimulationConfig: territories must be >= 1");
  return make_partition(config.partition, scene, config.territories, config.grid);
}

// A scene made in code is checked as a scene file is (docs/scene-format.md,
// within this build's precision envelope) before anything is built of it.
const Scene& checked(const Scene& scene) {
  validate_scene(scene, "Simulation: scene" + (scene.name.empty() ? std::string() : " '" + scene.name + "'"),
                 kDoublePrecision ? Precision::Double : Precision::Float);
  return scene;
}

}  // namespace

Simulation::Simulation(const Scene& scene, SimulationConfig config)
    : engine_(std::make_unique<SimulationEngine>(scene, partition_for(checked(scene), config), config)) {}

Simulation::Simulation(const Scene& scene, TerritoryMap map, SimulationConfig config)
    : engine_(std::make_unique<SimulationEngine>(checked(scene), std::move(map), std::move(config))) {}

namespace {

// The scene of a snapshot with every body where it is now: what the
// partition cuts and the home cells are taken from.
Scene scene_now(const WorldSnapshot& state) {
  Scene scene = scene_of(state);
  for (std::size_t i = 0; i < scene.bodies.size(); ++i) {
    const BodyDynamicState& d = state.bodies[i].state;
    scene.bodies[i].position = Vec3(d.origin[0], d.origin[1], d.origin[2]);
  }
  return scene;
}

}  // namespace

Simulation::Simulation(const SimulationSnapshot& snapshot, SimulationConfig config)
    : Simulation(snapshot, partition_for(scene_now(snapshot.state), config), config) {}

Simulation::Simulation(const SimulationSnapshot& snapshot, TerritoryMap map, SimulationConfig config)
    : engine_(std::make_unique<SimulationEngine>(snapshot, std::move(map), std::move(config))) {}

Simulation Simulation::resume(const std::string& path, SimulationConfig config) {
  return Simulation(read_checkpoint(path), std::move(config));
}

Simulation::~Simulation() = default;

namespace {

// Scene steps to internal steps, saturating at "no limit".
std::int64_t internal_steps(std::int64_t scene_steps, int substeps) {
  if (scene_steps >= RunControl::kUnlimited / substeps) return RunControl::kUnlimited;
  return scene_steps * substeps;
}

}  // namespace

void Simulation::start(std::optional<double> end_time) {
  const std::int64_t end = end_time ? engine_->core->step_at(*end_time) : RunControl::kUnlimited;
  engine_->start(internal_steps(end, engine_->substeps()));
}

bool Simulation::advance_to(double time) {
  const std::int64_t step = engine_->core->step_at(time);
  return engine_->advance_to(step);
}

bool Simulation::run_for(double seconds) {
  if (std::isnan(seconds) || seconds < 0) throw std::invalid_argument("Simulation::run_for: seconds must be >= 0");
  return advance_to(published_time() + seconds);
}

void Simulation::stop() { engine_->stop(); }

BodyId Simulation::add_body(double time, const Body& body) {
  UserInput in;
  in.kind = UserInput::Kind::AddBody;
  in.step = engine_->core->step_at(time);
  in.body = body;
  engine_->input(in);
  return body.id;
}

void Simulation::remove_body(double time, BodyId id) {
  UserInput in;
  in.kind = UserInput::Kind::RemoveBody;
  in.step = engine_->core->step_at(time);
  in.id = id;
  engine_->input(in);
}

void Simulation::set_velocity(double time, BodyId id, const Vec3& linear, const Vec3& angular) {
  UserInput in;
  in.kind = UserInput::Kind::SetVelocity;
  in.step = engine_->core->step_at(time);
  in.id = id;
  in.linear = linear;
  in.angular = angular;
  engine_->input(in);
}

void Simulation::apply_impulse(double time, BodyId id, const Vec3& impulse) {
  UserInput in;
  in.kind = UserInput::Kind::ApplyImpulse;
  in.step = engine_->core->step_at(time);
  in.id = id;
  in.linear = impulse;
  engine_->input(in);
}

void Simulation::set_gravity(double time, const Vec3& gravity) {
  UserInput in;
  in.kind = UserInput::Kind::SetGravity;
  in.step = engine_->core->step_at(time);
  in.linear = gravity;
  engine_->input(in);
}

namespace {

UserInput body_value(UserInput::Kind kind, std::int64_t step, BodyId id, double value) {
  UserInput in;
  in.kind = kind;
  in.step = step;
  in.id = id;
  in.value = value;
  return in;
}

}  // namespace

void Simulation::set_mass(double time, BodyId id, double mass) {
  engine_->input(body_value(UserInput::Kind::SetMass, engine_->core->step_at(time), id, mass));
}

void Simulation::set_friction(double time, BodyId id, double friction) {
  engine_->input(body_value(UserInput::Kind::SetFriction, engine_->core->step_at(time), id, friction));
}

void Simulation::set_restitution(double time, BodyId id, double restitution) {
  engine_->input(body_value(UserInput::Kind::SetRestitution, engine_->core->step_at(time), id, restitution));
}

void Simulation::set_user_data(double time, BodyId id, std::uint64_t user_data) {
  UserInput in = body_value(UserInput::Kind::SetUserData, engine_->core->step_at(time), id, 0.0);
  in.user_data = user_data;
  engine_->input(in);
}

void Simulation::set_collision_filter(double time, BodyId id, std::uint32_t group, std::uint32_t mask) {
  UserInput in = body_value(UserInput::Kind::SetCollisionFilter, engine_->core->step_at(time), id, 0.0);
  in.collision_group = group;
  in.collision_mask = mask;
  engine_->input(in);
}

namespace {

UserInput pose_input(UserInput::Kind kind, std::int64_t step, BodyId id, const Pose& pose) {
  UserInput in;
  in.kind = kind;
  in.step = step;
  in.id = id;
  in.linear = pose.position;
  in.orientation = pose.orientation;
  return in;
}

}  // namespace

void Simulation::set_kinematic_target(double time, BodyId id, const Pose& pose) {
  engine_->input(pose_input(UserInput::Kind::SetKinematicTarget, engine_->core->step_at(time), id, pose));
}

void Simulation::set_pose(double time, BodyId id, const Pose& pose) {
  engine_->input(pose_input(UserInput::Kind::SetPose, engine_->core->step_at(time), id, pose));
}

void Simulation::remove_joint(double time, JointId id) {
  UserInput in;
  in.kind = UserInput::Kind::RemoveJoint;
  in.step = engine_->core->step_at(time);
  in.joint = id;
  engine_->input(in);
}

void Simulation::add_joint(double time, const Joint& joint) {
  UserInput in;
  in.kind = UserInput::Kind::AddJoint;
  in.step = engine_->core->step_at(time);
  in.joint = joint.id;
  in.added_joint = joint;
  engine_->input(in);
}

void Simulation::set_joint_motor(double time, JointId id, bool on, double velocity, double max_impulse, int axis) {
  UserInput in;
  in.kind = UserInput::Kind::SetJointMotor;
  in.step = engine_->core->step_at(time);
  in.joint = id;
  in.motor = JointMotor{on, velocity, max_impulse, axis};
  engine_->input(in);
}

BodyId Simulation::give(const UserInput& input) {
  const double time = time_of(input.step);
  switch (input.kind) {
    case UserInput::Kind::AddBody: return add_body(time, input.body);
    case UserInput::Kind::RemoveBody: remove_body(time, input.id); break;
    case UserInput::Kind::SetVelocity: set_velocity(time, input.id, input.linear, input.angular); break;
    case UserInput::Kind::ApplyImpulse: apply_impulse(time, input.id, input.linear); break;
    case UserInput::Kind::SetGravity: set_gravity(time, input.linear); break;
    case UserInput::Kind::SetMass: set_mass(time, input.id, input.value); break;
    case UserInput::Kind::SetFriction: set_friction(time, input.id, input.value); break;
    case UserInput::Kind::SetRestitution: set_restitution(time, input.id, input.value); break;
    case UserInput::Kind::SetUserData: set_user_data(time, input.id, input.user_data); break;
    case UserInput::Kind::SetCollisionFilter:
      set_collision_filter(time, input.id, input.collision_group, input.collision_mask);
      break;
    case UserInput::Kind::SetPose: set_pose(time, input.id, Pose{input.linear, input.orientation}); break;
    case UserInput::Kind::SetKinematicTarget:
      set_kinematic_target(time, input.id, Pose{input.linear, input.orientation});
      break;
    case UserInput::Kind::RemoveJoint: remove_joint(time, input.joint); break;
    case UserInput::Kind::AddJoint: add_joint(time, input.added_joint); break;
    case UserInput::Kind::SetJointMotor:
      set_joint_motor(time, input.joint, input.motor.on, input.motor.velocity, input.motor.max_impulse,
                      input.motor.axis);
      break;
  }
  return input.id;
}

std::vector<std::int64_t> Simulation::published_steps() const { return engine_->core->control.published_steps(); }

std::vector<BufferMemory> Simulation::buffer_memory() const {
  std::vector<BufferMemory> out;
  for (const auto& b : engine_->core->buffers) out.push_back(b->memory());
  return out;
}
std::int64_t Simulation::commit_horizon_step() const { return engine_->commit_horizon_step(); }
std::uint64_t Simulation::rollbacks() const { return engine_->rollbacks(); }

std::vector<UserInput> Simulation::input_log() const { return engine_->input_log(); }

void Simulation::write_input_log(const std::string& path) const {
  const std::string text = inputs_to_json(input_log());
  std::ofstream out(path, std::ios::trunc);
  out << text;
  out.close();
  if (!out) throw std::runtime_error("cannot write the input log " + path);
}

SceneReader Simulation::add_reader() { return SceneReader(engine_->core, true); }

ContactReader Simulation::add_contact_reader(bool persist) {
  if (!engine_->core->contacts)
    throw std::logic_error("Simulation::add_contact_reader: contact events are off (SimulationConfig::contact_events)");
  return ContactReader(engine_->core, persist);
}

// A query only reads: it holds no pin, so a render thread may read a frame
// and query it (docs/embedding.md, "Final frames").
SceneQuery Simulation::add_query() { return SceneQuery(engine_->core, SceneReader(engine_->core, false)); }

SensorReader Simulation::add_sensor_reader() { return SensorReader(engine_->core->first_step, add_query()); }

double Simulation::dt() const { return engine_->core->dt; }
std::int64_t Simulation::step_at(double time) const { return engine_->core->step_at(time); }
double Simulation::time_of(std::int64_t step) const { return engine_->core->time_of(step); }
std::int64_t Simulation::published_step() const { return engine_->core->control.published_step(); }
bool Simulation::stopped() const { return engine_->stopped(); }
std::optional<SimulationError> Simulation::error() const { return engine_->core->control.error(); }
int Simulation::world_count() const { return engine_->world->world_count(); }
Schedule Simulation::schedule() const { return engine_->schedule; }
int Simulation::thread_count() const { return engine_->threads; }

std::int64_t Simulation::steps_done() const {
  engine_->wait_idle("steps_done");
  return engine_->world->world(0).steps_done() / engine_->substeps();
}

std::vector<BodyState> Simulation::body_states() const {
  engine_->wait_idle("body_states");
  return engine_->world->body_states();
}

std::uint64_t Simulation::state_hash() const {
  engine_->wait_idle("state_hash");
  return engine_->world->state_hash();
}

SimulationSnapshot Simulation::snapshot() const {
  engine_->wait_idle("snapshot");
  return engine_->snapshot();
}

std::int64_t Simulation::save(const std::string& path) const {
  const SimulationSnapshot snap = snapshot();
  write_checkpoint(snap, path);
  return snap.state.steps_done;
}

std::size_t Simulation::sleeping_count() const {
  engine_->wait_idle("sleeping_count");
  return engine_->world->sleeping_count();
}

std::size_t Simulation::body_count() const {
  engine_->wait_idle("body_count");
  return engine_->world->body_count();
}

std::vector<WorldMetrics> Simulation::metrics() const {
  engine_->wait_idle("metrics");
  return engine_->world->metrics();
}

}  // namespace soda
