// The precision envelope: how far from the origin, how small, how heavy or
// light, how fast and with how short a step a scene may be for a world of a
// given precision (btScalar float or double) to simulate what the scene says.
// Outside it a world does something else silently: a position that never
// changes (x + v h == x), a mass that rounds to 0 or inf (a "dynamic" body
// that cannot move), a step that rounds to 0. validate_scene refuses such
// scenes; docs/scene-format.md, "Precision envelope", gives the reasoning and
// the figures for both builds.
#pragma once

#include <numbers>

namespace soda {

/// Precision of the worlds' scalars: the float build (soda) and the double
/// build (soda-double).
enum class Precision { Float, Double };
/// "float" | "double".
const char* precision_name(Precision precision);

/// The slowest speed that still counts as motion: btRigidBody's default linear
/// sleeping threshold, which the worlds keep (a body slower than it for 2 s
/// falls asleep). A coordinate must be small enough that a body at this speed
/// still moves by at least one ulp per internal step. m/s.
inline constexpr double kSlowestSpeed = 0.8;
/// The envelope holds metre-scale scenes at the origin whatever the step:
/// the shortest step moves a body at kSlowestSpeed one ulp of this length. m.
inline constexpr double kUnitLength = 1.0;
/// A body's smallest half extent spans at least this many ulps of its
/// position's largest coordinate: its shape, contact points and penetration
/// depths are then resolved to about 3 % or better.
inline constexpr double kMinSizeInUlps = 32;
/// Bullet turns a body by at most this angle per internal step and silently
/// slows faster spins (ANGULAR_MOTION_THRESHOLD = pi/4 in btTransformUtil.h).
inline constexpr double kMaxStepRotation = std::numbers::pi / 4;

/// The limits for one precision and one internal step h = dt / substeps.
/// Plain data; all members in SI units.
struct PrecisionEnvelope {
  Precision precision = Precision::Double;
  double epsilon = 0;            // machine epsilon of the precision (ulp of 1)
  double max_finite = 0;         // largest finite value
  double step = 0;               // h = dt / substeps, s
  /// Shortest h: kSlowestSpeed * h >= epsilon * kUnitLength (which is also
  /// above Bullet's btFuzzyZero, below which stepSimulation does nothing). s.
  double min_step = 0;
  /// Largest |coordinate| of a dynamic body's position: kSlowestSpeed * h >=
  /// epsilon * |x|, so x + v h != x for every speed that counts. m.
  double max_position = 0;
  /// Range of a dynamic body's mass (kg) and of mass * size^2 (its moment of
  /// inertia's scale, kg m^2): the square roots of the precision's normal
  /// range, so that Bullet's products of two mass-scaled quantities (inverse
  /// mass times impulse, inverse inertia times lever arm squared, m v^2) and
  /// their inverses stay finite and normal.
  double min_mass = 0;
  double max_mass = 0;
  /// kMaxStepRotation / h, rad/s.
  double max_angular_speed = 0;

  static PrecisionEnvelope of(Precision precision, double dt, int substeps);
  /// Smallest half extent of a body whose largest |coordinate| is `coordinate`.
  double min_half_extent(double coordinate) const { return kMinSizeInUlps * epsilon * coordinate; }
};

}  // namespace soda
