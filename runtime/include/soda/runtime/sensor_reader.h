// runtime/ — the public embedding API. This header: sensor events, read per
// committed step. Include soda/runtime/simulation.h, which brings it.
//
// A sensor is a body with Body::sensor set: it never touches anything (the
// worlds filter its pairs out), and a SensorReader reports, for each
// committed step, the bodies each sensor's shape overlaps there and the
// begin and end events against the step before. The reader answers from the
// committed frame of the step as a SceneQuery does (every body placed from
// its frame pose and its description, Bullet's contact test of the sensor
// against each body it may touch), so the events are a function of the
// frames alone: bit-identical for any number of territories, partition,
// schedule or speculation, and never from a step that may still be rolled
// back (docs/contact-events.md, "Sensors").
//
//   soda::Simulation sim(scene, {.territories = 4});
//   soda::SensorReader sensors = sim.add_sensor_reader();
//   sim.start(5.0);
//   while (auto step = sensors.read_next())              // waits for each step
//     for (const soda::SensorEvent& e : step->events)
//       if (e.kind == soda::SensorEventKind::Begin) open_door(e.sensor, e.body);
//
// What a sensor reports: every body that is not a sensor, whose collision
// group shares a bit with the sensor's collision mask and whose shape
// touches or penetrates the sensor's at the step (a contact point at
// distance <= 0); static bodies too, except for a static sensor (its
// overlaps with statics never change). Sensors never report each other.
#pragma once

#include <compare>
#include <cstdint>
#include <optional>
#include <vector>

#include "soda/runtime/scene_query.h"

namespace soda {

enum class SensorEventKind : std::uint8_t {
  Begin = 0,  // the body overlaps the sensor at this step, not at the step before
  End = 2,    // it did at the step before, and does not at this step (or is gone)
};

/// "begin" or "end".
const char* to_string(SensorEventKind kind);

/// A body inside a sensor at one step.
struct SensorOverlap {
  BodyId sensor = 0;
  BodyId body = 0;
  auto operator<=>(const SensorOverlap&) const = default;
};

/// A body entering or leaving a sensor at one committed step.
struct SensorEvent {
  std::int64_t step = 0;
  SensorEventKind kind = SensorEventKind::Begin;
  BodyId sensor = 0;
  BodyId body = 0;
};

/// What the sensors saw at one committed step.
struct SensorStep {
  std::int64_t step = 0;
  double time = 0.0;                   // step * dt, s
  std::vector<SensorEvent> events;     // ascending by (sensor, body)
  std::vector<SensorOverlap> inside;   // every overlap at this step, ascending
};

/// 64-bit FNV-1a over the events (step, kind, sensor, body) of `steps` in
/// order: equal streams, equal hashes. Pure.
std::uint64_t sensor_stream_hash(const std::vector<SensorStep>& steps);

/// A cursor that reads sensor events, made by
/// Simulation::add_sensor_reader(). It holds a SceneQuery (its cursors pin
/// frames as a reader's do: destroy a sensor reader you no longer use).
///
/// Reads go forward: read_step(s) for s after the last step read (the last
/// one may be read again: the same events); a step skipped over is diffed
/// against the step before it, which must still be held.
///
/// Thread safety: one thread at a time per reader; readers, queries and the
/// Simulation's calls may run concurrently.
class SensorReader {
 public:
  SensorReader(SensorReader&&) noexcept;
  SensorReader& operator=(SensorReader&&) noexcept;
  SensorReader(const SensorReader&) = delete;
  SensorReader& operator=(const SensorReader&) = delete;
  ~SensorReader();

  /// The sensor events of scene step `step`, once every world has published
  /// it and it is final (waits). At the run's first step (0, or a
  /// snapshot's) every overlap begins. nullopt if the step or the step
  /// before it is gone (freed, or before the last step read) or the
  /// Simulation stopped before publishing it. Throws SimulationError if a
  /// world failed while it waited, std::invalid_argument for a step before
  /// the run's first. Reader's thread.
  std::optional<SensorStep> read_step(std::int64_t step);

  /// As read_step, but never waits: nullopt also when the step is not
  /// final yet.
  std::optional<SensorStep> try_read_step(std::int64_t step);

  /// read_step(last_step() + 1) (the run's first step before any read).
  std::optional<SensorStep> read_next();

  /// Step of the last events returned; -1 before the first read.
  std::int64_t last_step() const { return last_.step < 0 ? -1 : last_.step; }

 private:
  friend class Simulation;
  SensorReader(std::int64_t first_step, SceneQuery query);
  std::optional<SensorStep> read(std::int64_t step, bool wait);

  std::int64_t first_step_ = 0;
  SceneQuery query_;
  SensorStep last_{-1, 0.0, {}, {}};  // the last step returned
};

}  // namespace soda
