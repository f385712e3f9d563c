// rollback/ — buffers, snapshots and repair. This header: what one world
// publishes per step (a TransformEntry of BodyPoses), and how a pose between
// two published steps is interpolated.
//
// Precision: Real is the world's Bullet scalar (float for Debian's `bullet`,
// double for `bullet-float64`); times are always double seconds.
#pragma once

#include <cstdint>
#include <vector>

#include "soda/scene/scene.h"

namespace soda {

/// State of one body at the end of a step. Units: m, m/s, rad/s; world frame.
template <class Real>
struct BodyPose {
  BodyId id = 0;
  Real position[3] = {0, 0, 0};
  Real orientation[4] = {0, 0, 0, 1};  // unit quaternion x, y, z, w
  Real linear_velocity[3] = {0, 0, 0};
  Real angular_velocity[3] = {0, 0, 0};
  /// Asleep at the end of the step (Bullet's ISLAND_SLEEPING): for viewers
  /// and replay files (soda run --record); no physics reads it.
  bool sleeping = false;
};

/// One contact point of a pair at the end of a step, as Bullet's
/// btManifoldPoint holds it after the step's solve (world frame, m, N s).
template <class Real>
struct PairContactPoint {
  Real position_on_a[3] = {0, 0, 0};  // getPositionWorldOnA: on the lower-id body
  Real position_on_b[3] = {0, 0, 0};  // getPositionWorldOnB: on the higher-id body
  Real normal_on_b[3] = {0, 0, 0};    // m_normalWorldOnB: unit, from b towards a
  Real distance = 0;                  // getDistance: < 0 penetrating, m
  Real impulse = 0;                   // getAppliedImpulse: the normal impulse of the step's solve, N s
};

/// The contact state of one pair at the end of a step: a persistent manifold
/// with points (at most 4, in Bullet's cache order). a < b are body ids.
template <class Real>
struct PairContact {
  BodyId a = 0;
  BodyId b = 0;
  std::uint32_t point_count = 0;  // 1..4
  PairContactPoint<Real> points[4];
};

/// What a world publishes for one step. Immutable once published.
template <class Real>
struct TransformEntry {
  std::int64_t step = 0;        // the world's local step this entry ends
  double time = 0.0;            // simulated time at the end of `step`, s
  std::uint64_t revision = 0;   // set by the buffer: 0, then +1 per rewrite
  std::vector<BodyPose<Real>> poses;  // strictly increasing by id
  /// Thread CPU time the world spent since its previous entry (the step's
  /// stages, a rollback's re-runs included), seconds; 0 for step 0. For
  /// viewers' per-world load (replay files); no physics reads it.
  double busy_seconds = 0.0;
  /// The contacts of the pairs this world reports at the end of `step`,
  /// strictly increasing by (a, b); empty unless contacts are recorded
  /// (SimulationConfig::contact_events). Carried as published.
  std::vector<PairContact<Real>> contacts;
};

/// Poses at a time between two consecutive entries (see interpolate_entries).
template <class Real>
struct PoseSample {
  double time = 0.0;                  // the requested time, s
  std::int64_t before_step = 0;       // entry at or before `time`
  std::uint64_t before_revision = 0;
  std::int64_t after_step = 0;        // next entry; == before_step when none
  std::uint64_t after_revision = 0;
  double weight = 0.0;                // in [0, 1]: 0 is `before`, 1 `after`
  std::vector<BodyPose<Real>> poses;  // strictly increasing by id
};

/// Pose at weight w in [0, 1] between a (w = 0) and b (w = 1): position and
/// both velocities linear (a + (b - a) * w), orientation by slerp along the
/// shorter arc, renormalised (nlerp when |cos| of the angle between the two
/// quaternions exceeds 0.9995, where they differ by at most ~1e-6 rad).
/// w == 0 returns a unchanged, bit for bit. The id and sleeping flag are a's. Thread-safe.
template <class Real>
BodyPose<Real> interpolate_pose(const BodyPose<Real>& a, const BodyPose<Real>& b, Real w);

/// Poses at `time` between `before` and `after` (after.step == before.step+1,
/// or `after` is `before` itself when there is no later entry). The weight is
/// (time - before.time) / (after.time - before.time), clamped to [0, 1]. The
/// result holds exactly the bodies of `before`: those also in `after` are
/// interpolated, the others (they leave the world at after.step) keep their
/// `before` pose. Bodies that appear only in `after` are not yet there.
/// Pure function; thread-safe.
template <class Real>
PoseSample<Real> interpolate_entries(const TransformEntry<Real>& before,
                                     const TransformEntry<Real>& after, double time);

}  // namespace soda
