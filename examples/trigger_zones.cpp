// Trigger zones (docs/contact-events.md, "Sensors"): cubes dropped on a
// floor, on 2 territories that speculate (worlds run up to 8 steps ahead and
// roll back lost bets). Two sensors watch them: a "checkpoint gate", a thin
// static slab the cubes fall through halfway down, and a "goal" box on the
// floor that only counts cubes of collision group 2 (every other cube). A
// sensor pushes nothing: the cubes fall as if it were not there. The game's
// loop reads the sensor events of every committed step as they come and
// prints who entered and left; no event ever comes from a step a rollback
// takes back. The same scene on one world gives the same events; the run
// ends on the one-world state hash and sensor stream hash.
// Usage: trigger_zones [N] [SECONDS]   (N cubes, default 200; default 3 s)
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <vector>

#include "soda/runtime/simulation.h"

namespace {

soda::Body zone(soda::BodyId id, const soda::Vec3& at, const soda::Vec3& half_extents, std::uint32_t mask) {
  soda::Body b;
  b.id = id;
  b.is_static = true;
  b.sensor = true;
  b.shape = soda::Shape::box(half_extents);
  b.position = at;
  b.collision_mask = mask;
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const int n = argc > 1 ? std::atoi(argv[1]) : 200;
    const double seconds = argc > 2 ? std::atof(argv[2]) : 3.0;
    soda::Scene scene = soda::make_scene("falling-cubes", {n, 1});
    soda::Vec3 lo = soda::Vec3::Constant(1e30), hi = soda::Vec3::Constant(-1e30);
    soda::BodyId next = 0;
    int k = 0;
    for (soda::Body& b : scene.bodies) {
      next = std::max(next, b.id + 1);
      if (b.is_static) continue;
      lo = lo.cwiseMin(b.position), hi = hi.cwiseMax(b.position);
      if (k++ % 2 == 1) b.collision_group = 2;  // the cubes the goal counts
    }
    const soda::Vec3 mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo) + soda::Vec3(1, 1, 1);
    const soda::BodyId gate = next, goal = next + 1;
    scene.bodies.push_back(zone(gate, {mid.x(), mid.y(), mid.z()}, {half.x(), 0.25, half.z()}, soda::kAllCollisionGroups));
    scene.bodies.push_back(zone(goal, {mid.x(), 0.5, mid.z()}, {0.5 * half.x(), 0.5, 0.5 * half.z()}, 2));

    soda::SimulationConfig config{.territories = 2};
    config.runtime.anticipation = 8;
    soda::Simulation sim(scene, config);
    soda::SensorReader sensors = sim.add_sensor_reader();
    sim.start(seconds);
    std::vector<soda::SensorStep> seen;
    std::size_t printed = 0, through_gate = 0, scored = 0;
    for (std::int64_t s = 0; s <= sim.step_at(seconds); ++s) {
      std::optional<soda::SensorStep> step = sensors.read_step(s);  // waits for step s to be final
      if (!step) break;
      if (s == 0) std::printf("t = 0: %zu cubes start inside the gate\n", step->inside.size());
      for (const soda::SensorEvent& e : step->events) {
        if (e.kind == soda::SensorEventKind::Begin) (e.sensor == gate ? through_gate : scored) += 1;
        if (s > 0 && ++printed <= 20)
          std::printf("t = %.3f s (step %lld): cube %u %s the %s\n", step->time, static_cast<long long>(step->step),
                      e.body, e.kind == soda::SensorEventKind::Begin ? "enters" : "leaves",
                      e.sensor == gate ? "gate" : "goal");
      }
      seen.push_back(std::move(*step));
    }
    sim.advance_to(seconds);
    const std::uint64_t hash = sim.state_hash();
    sim.stop();
    if (printed > 20) std::printf("... and %zu more events\n", printed - 20);

    soda::Simulation one(scene, {.threads = 1});
    soda::SensorReader reader = one.add_sensor_reader();
    one.start(seconds);
    std::vector<soda::SensorStep> expected;
    for (std::int64_t s = 0; s < static_cast<std::int64_t>(seen.size()); ++s)
      if (auto step = reader.read_step(s)) expected.push_back(*step);
    one.advance_to(seconds);
    const std::uint64_t events = soda::sensor_stream_hash(seen), one_events = soda::sensor_stream_hash(expected);
    const bool ok = hash == one.state_hash() && events == one_events && seen.size() == expected.size();
    std::printf("%zu steps, %zu cubes through the gate, %zu goals; state hash %016llx, one world %016llx; sensor "
                "stream %016llx, one world %016llx: %s\n",
                seen.size(), through_gate, scored, static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(one.state_hash()), static_cast<unsigned long long>(events),
                static_cast<unsigned long long>(one_events), ok ? "equal" : "DIFFERENT");
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "trigger_zones: %s\n", e.what());
    return 1;
  }
}
