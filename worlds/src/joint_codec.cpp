// Byte encoding of joints and their broken flag (value_codec.h,
// write_joint / read_joint).
#include "soda/worlds/value_codec.h"

namespace soda {

void write_joint(ByteWriter& w, const JointSnapshot& js) {
  const Joint& j = js.description;
  w.put(j.id);
  w.put(static_cast<std::uint8_t>(j.kind));
  w.put(j.body_a), w.put(j.body_b);
  for (const JointFrame* f : {&j.frame_a, &j.frame_b}) {
    w.vec3(f->position);
    w.put(f->orientation.x()), w.put(f->orientation.y()), w.put(f->orientation.z()), w.put(f->orientation.w());
  }
  w.put(static_cast<std::uint8_t>(j.collide_connected));
  w.put(j.breaking_impulse);
  w.put(static_cast<std::uint8_t>(j.limited));
  w.put(j.lower), w.put(j.upper), w.put(j.angular_lower), w.put(j.angular_upper);
  w.put(static_cast<std::uint8_t>(j.motor));
  w.put(j.motor_velocity), w.put(j.motor_max_impulse);
  w.put(j.swing_span1), w.put(j.swing_span2), w.put(j.twist_span);
  for (const auto* a : {&j.axis_lower, &j.axis_upper, &j.stiffness, &j.damping, &j.motor_velocities, &j.motor_max_forces})
    for (double v : *a) w.put(v);
  w.put(static_cast<std::uint8_t>(js.broken));
}

namespace {

bool read_joint_flag(ByteReader& r) {
  const auto v = r.get<std::uint8_t>();
  if (v > 1) r.fail("bad flag");
  return v == 1;
}

}  // namespace

JointSnapshot read_joint(ByteReader& r) {
  JointSnapshot js;
  Joint& j = js.description;
  j.id = r.get<JointId>();
  const auto kind = r.get<std::uint8_t>();
  if (kind > static_cast<std::uint8_t>(JointKind::Spring6Dof)) r.fail("unknown joint kind");
  j.kind = static_cast<JointKind>(kind);
  j.body_a = r.get<BodyId>(), j.body_b = r.get<BodyId>();
  for (JointFrame* f : {&j.frame_a, &j.frame_b}) {
    f->position = r.vec3();
    const double x = r.finite(), y = r.finite(), z = r.finite(), qw = r.finite();
    f->orientation = Quat(qw, x, y, z);
  }
  j.collide_connected = read_joint_flag(r);
  j.breaking_impulse = r.get<double>();  // infinity: never breaks
  if (!(j.breaking_impulse > 0)) r.fail("bad joint breaking impulse");
  j.limited = read_joint_flag(r);
  j.lower = r.finite(), j.upper = r.finite(), j.angular_lower = r.finite(), j.angular_upper = r.finite();
  j.motor = read_joint_flag(r);
  j.motor_velocity = r.finite(), j.motor_max_impulse = r.finite();
  j.swing_span1 = r.finite(), j.swing_span2 = r.finite(), j.twist_span = r.finite();
  for (auto* a : {&j.axis_lower, &j.axis_upper, &j.stiffness, &j.damping, &j.motor_velocities, &j.motor_max_forces})
    for (double& v : *a) v = r.finite();
  js.broken = read_joint_flag(r);
  return js;
}

}  // namespace soda
