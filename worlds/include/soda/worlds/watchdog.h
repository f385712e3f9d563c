// worlds/ — the watchdog: after every step each world checks its own bodies
// for states a physics engine must never produce — NaN or Inf anywhere in a
// body's transform or velocities, absurd linear or angular speeds, deep
// penetrations in the contacts it holds — and the runtime responds as
// configured: stop with an error naming the step, the world and the bodies,
// or self-heal (roll back to the last good step and re-simulate the bad one
// with substeps; PartitionedWorld, docs/watchdog.md).
//
// The check reads only the end-of-step state of owned bodies and the
// contacts a world holds, so the union of the worlds' findings is the
// one-world run's findings: the verdict, like the physics, does not depend
// on the number of territories.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda {

/// What a run does when a world's check finds something.
enum class WatchdogResponse {
  Off,   // no check
  Stop,  // throw WatchdogError (a SimulationError's cause under a Simulation)
  Heal,  // roll back to the last good step, re-simulate the bad step with substeps
};
const char* watchdog_response_name(WatchdogResponse response);
/// "off" | "stop" | "heal"; throws std::invalid_argument naming the choices.
WatchdogResponse parse_watchdog_response(const std::string& text);

/// Thresholds. The defaults are far outside anything the project's scenes do
/// (the fastest, bullet-vs-wall, reaches 500 m/s; resting contacts carry
/// millimetres of penetration, impacts up to one step of travel) and far
/// inside what a blown-up solver produces (1e6 m/s and more within a step or
/// two of going unstable).
struct WatchdogLimits {
  double max_speed = 1e4;           // m/s, |linear velocity|
  double max_angular_speed = 1e4;   // rad/s, |angular velocity|
  double max_penetration = 1.0;     // m, depth of any contact point held (-distance)
};

struct WatchdogConfig {
  WatchdogResponse response = WatchdogResponse::Stop;
  WatchdogLimits limits = {};
  int heal_substeps = 8;  // Heal: the bad step is re-simulated as this many substeps
  int max_heals = 10;     // Heal: more heals than this in one run stop it (WatchdogError)
};

struct WatchdogFinding {
  enum class Kind { NonFinite, Speed, AngularSpeed, Penetration };
  Kind kind = Kind::NonFinite;
  BodyId body = 0;
  BodyId other = 0;   // Penetration: the other body of the contact
  double value = 0;   // the speed, angular speed or depth found (NaN for NonFinite)
};
/// "body 42: non-finite state", "body 7: speed 1.2e+06 m/s > 10000", ...
std::string describe(const WatchdogFinding& finding, const WatchdogLimits& limits);

/// A world's check found something at a step.
class WatchdogError : public std::runtime_error {
 public:
  WatchdogError(std::int64_t step, WorldId world, std::vector<WatchdogFinding> findings, const WatchdogLimits& limits,
                const std::string& context = "");
  /// The scene step whose end state failed the check (1 = the first step).
  std::int64_t step() const noexcept { return step_; }
  WorldId world() const noexcept { return world_; }
  const std::vector<WatchdogFinding>& findings() const noexcept { return findings_; }

 private:
  std::int64_t step_;
  WorldId world_;
  std::vector<WatchdogFinding> findings_;
};

}  // namespace soda
