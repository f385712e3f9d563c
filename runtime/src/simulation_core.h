// Internal: the part of a Simulation its readers share (and may outlive it
// with): one transform buffer per world and the RunControl.
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

#include "run_control.h"
#include "soda/rollback/transform_buffer.h"

namespace soda {

struct SimulationCore {
  SimulationCore(int worlds, int substeps, double dt, std::size_t dynamic_bodies, std::size_t capacity, bool delta)
      : dt(dt), dynamic_bodies(dynamic_bodies), control(worlds, substeps) {
    for (int w = 0; w < worlds; ++w) buffers.push_back(std::make_unique<TransformBuffer<btScalar>>(capacity, delta));
  }

  /// The scene step at or before `time`; within 1e-9 of a step counts as it
  /// (so k * dt and k / rate hit step k whatever the rounding).
  std::int64_t step_at(double time) const {
    if (std::isnan(time) || time < 0) throw std::invalid_argument("simulation time must be >= 0 (got NaN or negative)");
    const double q = time / dt;
    if (q >= static_cast<double>(RunControl::kUnlimited)) return RunControl::kUnlimited;
    const double r = std::nearbyint(q);
    if (std::abs(q - r) <= 1e-9 * std::max(1.0, r)) return static_cast<std::int64_t>(r);
    return static_cast<std::int64_t>(std::floor(q));
  }
  double time_of(std::int64_t step) const { return scene_time(step, dt); }

  const double dt;
  const std::size_t dynamic_bodies;
  RunControl control;
  std::vector<std::unique_ptr<TransformBuffer<btScalar>>> buffers;  // by world id
};

}  // namespace soda
