// Internal: the part of a Simulation its readers share (and may outlive it
// with): one transform buffer per world, the RunControl, the census of the
// bodies each frame holds, and the commit horizon that decides when a frame
// is final.
//
// A frame is *final* when no rollback can change it any more. Without
// speculation and past inputs every published frame is final. With either,
// a frame of step s is final once the commit horizon (GVT) has reached s:
// a rollback restores a step boundary at or above GVT and rewrites only the
// entries after it, and an input at step s changes frames s + 1 on. Readers
// serve final frames only, so a frame never changes once read.
//
// Reader pins (with past inputs): each reader holds the horizon at the
// newest step it uses (the frame it returned; for an interpolation, the
// later of its two frames), so that an input at the frame on screen is
// still accepted; moving on releases the pin. docs/embedding.md, "The game
// loop".
#pragma once

#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <vector>

#include "embedding/census.h"
#include "embedding/run_control.h"
#include "soda/rollback/commit_horizon.h"
#include "soda/rollback/transform_buffer.h"

namespace soda {

struct SimulationCore {
  /// The first frame is that of scene step `start`.
  SimulationCore(const Scene& scene, int worlds, int substeps, std::int64_t start, std::size_t capacity, bool delta)
      : dt(scene.settings.dt), substeps(substeps), first_step(start), census(scene), control(worlds, substeps, start) {
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

  /// Whether the frame of `step` (published by every world) can no longer
  /// change. Any thread.
  bool is_final(std::int64_t step) const { return !gate || horizon->gvt() >= step * substeps; }

  /// Reader pins: holds the horizon at `step` from now on (reader_pins
  /// only). Returns the step pinned (>= the horizon's highest value).
  std::int64_t pin_first() const {
    for (;;) {
      const std::int64_t step = (horizon->highest_gvt() + substeps - 1) / substeps;
      horizon->pin_reader(step * substeps);
      if (horizon->highest_gvt() <= step * substeps) return step;
      horizon->unpin_reader(step * substeps);  // the horizon passed it meanwhile: again
    }
  }
  /// Moves a reader's pin from `from` forward to `to` (no-op unless to > from).
  void move_pin(std::int64_t from, std::int64_t to) const {
    if (to <= from) return;
    horizon->pin_reader(to * substeps);
    horizon->unpin_reader(from * substeps);
  }
  void unpin(std::int64_t step) const { horizon->unpin_reader(step * substeps); }

  const double dt;
  const int substeps;
  const std::int64_t first_step;  // the scene step of the first frame
  Census census;  // the bodies each step's frame holds
  RunControl control;
  std::vector<std::unique_ptr<TransformBuffer<btScalar>>> buffers;  // by world id
  /// Set once by the engine before any reader exists.
  std::shared_ptr<CommitHorizon> horizon;
  bool gate = false;         // frames wait for the horizon (speculation or past inputs)
  bool reader_pins = false;  // readers pin the horizon (past inputs)
  bool contacts = false;     // entries carry contacts (SimulationConfig::contact_events)
};

/// What one pass over every world's buffer found for a step.
enum class Gathered { Frame, NotYet, Gone };

/// One pass over every world's buffer for scene step `step` (never stopping
/// early): with move_cursors, each reader cursor `ids[w]` moves to world w's
/// newest entry at or before the step (scene_reader.cpp says why every
/// cursor must move); without, entries are looked up without a cursor (for
/// steps at or after the cursors, which keep them from being freed). Frame:
/// every world's entry of `step` is in `out` and the step is final; Gone:
/// some world holds nothing at or before it; NotYet otherwise. Any thread.
Gathered gather_entries(SimulationCore& core, const std::vector<BufferReaderId>& ids, std::int64_t step,
                        bool move_cursors, std::vector<std::shared_ptr<const TransformEntry<btScalar>>>& out);

}  // namespace soda
