// Interpolation between two published steps (for readers that show times
// between steps, e.g. a renderer at a fixed frame rate).
#include "soda/rollback/transform_entry.h"

#include <algorithm>
#include <cmath>

namespace soda {
namespace {

// Above this |cos| of the angle between two quaternions, slerp's sin(angle)
// divisor loses precision, and nlerp stays within ~1e-6 rad of slerp (the
// rotation angle error, measured at the threshold). The usual choice.
constexpr double kSlerpNlerpThreshold = 0.9995;

template <class Real>
void lerp3(const Real (&a)[3], const Real (&b)[3], Real w, Real (&out)[3]) {
  for (int k = 0; k < 3; ++k) out[k] = a[k] + (b[k] - a[k]) * w;
}

template <class Real>
void slerp(const Real (&a)[4], const Real (&b)[4], Real w, Real (&out)[4]) {
  Real cos_angle = 0;
  for (int k = 0; k < 4; ++k) cos_angle += a[k] * b[k];
  const Real sign = cos_angle < 0 ? Real(-1) : Real(1);  // shorter arc: q and -q are one rotation
  cos_angle *= sign;
  Real wa = Real(1) - w;
  Real wb = w;
  if (cos_angle < Real(kSlerpNlerpThreshold)) {
    const Real angle = std::acos(cos_angle);
    const Real sin_angle = std::sin(angle);
    wa = std::sin((Real(1) - w) * angle) / sin_angle;
    wb = std::sin(w * angle) / sin_angle;
  }
  Real norm2 = 0;
  for (int k = 0; k < 4; ++k) {
    out[k] = wa * a[k] + sign * wb * b[k];
    norm2 += out[k] * out[k];
  }
  const Real inv_norm = Real(1) / std::sqrt(norm2);
  for (int k = 0; k < 4; ++k) out[k] *= inv_norm;
}

}  // namespace

template <class Real>
BodyPose<Real> interpolate_pose(const BodyPose<Real>& a, const BodyPose<Real>& b, Real w) {
  if (w == Real(0)) return a;
  BodyPose<Real> out;
  out.id = a.id;
  out.sleeping = a.sleeping;
  lerp3(a.position, b.position, w, out.position);
  slerp(a.orientation, b.orientation, w, out.orientation);
  lerp3(a.linear_velocity, b.linear_velocity, w, out.linear_velocity);
  lerp3(a.angular_velocity, b.angular_velocity, w, out.angular_velocity);
  return out;
}

template <class Real>
PoseSample<Real> interpolate_entries(const TransformEntry<Real>& before,
                                     const TransformEntry<Real>& after, double time) {
  PoseSample<Real> sample;
  sample.time = time;
  sample.before_step = before.step;
  sample.before_revision = before.revision;
  sample.after_step = after.step;
  sample.after_revision = after.revision;
  const double span = after.time - before.time;
  sample.weight = span > 0 ? std::clamp((time - before.time) / span, 0.0, 1.0) : 0.0;
  const Real w = static_cast<Real>(sample.weight);

  sample.poses.reserve(before.poses.size());
  auto next = after.poses.begin();  // both lists are sorted by id: one merge pass
  for (const BodyPose<Real>& pose : before.poses) {
    next = std::lower_bound(next, after.poses.end(), pose.id,
                            [](const BodyPose<Real>& p, BodyId id) { return p.id < id; });
    if (next != after.poses.end() && next->id == pose.id) {
      sample.poses.push_back(interpolate_pose(pose, *next, w));
    } else {
      sample.poses.push_back(pose);
    }
  }
  return sample;
}

template BodyPose<float> interpolate_pose(const BodyPose<float>&, const BodyPose<float>&, float);
template BodyPose<double> interpolate_pose(const BodyPose<double>&, const BodyPose<double>&,
                                           double);
template PoseSample<float> interpolate_entries(const TransformEntry<float>&,
                                               const TransformEntry<float>&, double);
template PoseSample<double> interpolate_entries(const TransformEntry<double>&,
                                                const TransformEntry<double>&, double);

}  // namespace soda
