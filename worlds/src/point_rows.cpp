// The rows of one contact point set up together (point_rows.h). The
// comments name the Bullet fields and expressions (3.24,
// btSequentialImpulseConstraintSolver.cpp) whose bits each part gives.
#include "point_rows.h"

#include <cstdint>
#include <cstring>
#include <type_traits>

namespace soda {
namespace {

// Lane 0: the contact row; lanes 1, 2: the friction rows; lane 3 repeats
// lane 2. A GCC vector of four btScalars (one SSE register of floats, two of
// doubles): its operations are IEEE, lane by lane, never reassociated.
using L4 = btScalar __attribute__((vector_size(4 * sizeof(btScalar))));
// Four doubles are one AVX register, passed differently with and without
// AVX: GCC warns for every function taking or returning one. These
// functions are this file's own (internal linkage), so no call crosses
// between code built with and without AVX.
#pragma GCC diagnostic ignored "-Wpsabi"
// Shuffle masks of L4 (lane indices, 0-3 the first operand, 4-7 the second).
using LaneIndex = std::conditional_t<sizeof(btScalar) == 4, std::int32_t, std::int64_t>;
using I4 = LaneIndex __attribute__((vector_size(4 * sizeof(LaneIndex))));

struct Vec {  // a vector per lane
  L4 x, y, z;
};

L4 load(const btVector3& v) {
  L4 r;
  static_assert(sizeof(r) == sizeof(v.m_floats));
  std::memcpy(&r, v.m_floats, sizeof(r));
  return r;
}

// Four vectors (x, y, z, w) into lanes (w dropped).
Vec lanes(const btVector3& v0, const btVector3& v1, const btVector3& v2, const btVector3& v3) {
  const L4 a = load(v0), b = load(v1), c = load(v2), d = load(v3);
  const L4 ab_lo = __builtin_shuffle(a, b, I4{0, 4, 1, 5});  // a.x b.x a.y b.y
  const L4 cd_lo = __builtin_shuffle(c, d, I4{0, 4, 1, 5});
  const L4 ab_hi = __builtin_shuffle(a, b, I4{2, 6, 3, 7});  // a.z b.z a.w b.w
  const L4 cd_hi = __builtin_shuffle(c, d, I4{2, 6, 3, 7});
  return {__builtin_shuffle(ab_lo, cd_lo, I4{0, 1, 4, 5}), __builtin_shuffle(ab_lo, cd_lo, I4{2, 3, 6, 7}),
          __builtin_shuffle(ab_hi, cd_hi, I4{0, 1, 4, 5})};
}

// Lanes 0 .. Rows - 1 of `v` into the rows' `field` as btVector3(x, y, z)
// (w 0).
template <int Rows>
void store(const Vec& v, btSolverConstraint* const* row, btVector3 btSolverConstraint::*field) {
  const L4 zero = {0, 0, 0, 0};
  const L4 xy_lo = __builtin_shuffle(v.x, v.y, I4{0, 4, 1, 5});  // x0 y0 x1 y1
  const L4 z0_lo = __builtin_shuffle(v.z, zero, I4{0, 4, 1, 5});  // z0 0 z1 0
  const L4 r0 = __builtin_shuffle(xy_lo, z0_lo, I4{0, 1, 4, 5});
  const L4 r1 = __builtin_shuffle(xy_lo, z0_lo, I4{2, 3, 6, 7});
  std::memcpy((row[0]->*field).m_floats, &r0, sizeof(r0));
  std::memcpy((row[1]->*field).m_floats, &r1, sizeof(r1));
  if constexpr (Rows > 2) {
    const L4 xy_hi = __builtin_shuffle(v.x, v.y, I4{2, 6, 3, 7});  // x2 y2 x3 y3
    const L4 z0_hi = __builtin_shuffle(v.z, zero, I4{2, 6, 3, 7});
    const L4 r2 = __builtin_shuffle(xy_hi, z0_hi, I4{0, 1, 4, 5});
    std::memcpy((row[2]->*field).m_floats, &r2, sizeof(r2));
  }
}

// r.cross(a) for a vector r shared by the lanes (btVector3::cross).
Vec cross(const btVector3& r, const Vec& a) {
  return {r.y() * a.z - r.z() * a.y, r.z() * a.x - r.x() * a.z, r.x() * a.y - r.y() * a.x};
}

// a.cross(r).
Vec cross(const Vec& a, const btVector3& r) {
  return {a.y * r.z() - a.z * r.y(), a.z * r.x() - a.x * r.z(), a.x * r.y() - a.y * r.x()};
}

// (m * t) * f: btMatrix3x3 times a vector (each row's dot), then times a
// vector element by element, as in `getInvInertiaTensorWorld() * t *
// getAngularFactor()`.
Vec angular(const btMatrix3x3& m, const Vec& t, const btVector3& f) {
  const btVector3 &r0 = m[0], &r1 = m[1], &r2 = m[2];
  return {(r0.x() * t.x + r0.y() * t.y + r0.z() * t.z) * f.x(), (r1.x() * t.x + r1.y() * t.y + r1.z() * t.z) * f.y(),
          (r2.x() * t.x + r2.y() * t.y + r2.z() * t.z) * f.z()};
}

// a.dot(b), lane by lane.
L4 dot(const Vec& a, const Vec& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }

Vec operator-(const Vec& a) { return {-a.x, -a.y, -a.z}; }

// The contact row's scalars (setupContactConstraint after the vectors):
// denom its denom0 + denom1, rel_vel0 its vel1Dotn + vel2Dotn.
void contact_row(btSolverConstraint& c, btScalar denom, btScalar rel_vel0, const btSolverBody& a,
                 const btSolverBody& b, int id_a, int id_b, btManifoldPoint& cp, const btVector3& rel_pos1,
                 const btVector3& rel_pos2, const btContactSolverInfo& info) {
  const btRigidBody* rb0 = a.m_originalBody;
  const btRigidBody* rb1 = b.m_originalBody;
  const btVector3 zero3(0, 0, 0);
  const btScalar inv_time_step = btScalar(1) / info.m_timeStep;
  const btScalar cfm = info.m_globalCfm * inv_time_step;
  const btScalar erp = info.m_erp2;
  const btScalar jac0 = info.m_sor / (denom + cfm);  // relaxation / (denom0 + denom1 + cfm)
  c.m_solverBodyIdA = id_a;
  c.m_solverBodyIdB = id_b;
  c.m_originalContactPoint = &cp;
  c.m_jacDiagABInv = jac0;
  c.m_friction = cp.m_combinedFriction;
  // restitutionCurve of the bodies' own velocities at the point.
  const btVector3 v1 = rb0 ? rb0->getVelocityInLocalPoint(rel_pos1) : zero3;
  const btVector3 v2 = rb1 ? rb1->getVelocityInLocalPoint(rel_pos2) : zero3;
  const btScalar point_vel = cp.m_normalWorldOnB.dot(v1 - v2);
  btScalar restitution =
      btFabs(point_vel) < info.m_restitutionVelocityThreshold ? btScalar(0.) : cp.m_combinedRestitution * -point_vel;
  if (restitution <= btScalar(0.)) restitution = 0.f;
  c.m_appliedImpulse = 0.f;
  c.m_appliedPushImpulse = 0.f;
  const btScalar penetration = cp.getDistance() + info.m_linearSlop;
  btScalar positional_error = 0.f;
  btScalar velocity_error = restitution - rel_vel0;
  if (penetration > 0) {
    positional_error = 0;
    velocity_error -= penetration * inv_time_step;
  } else {
    positional_error = -penetration * erp * inv_time_step;
  }
  const btScalar penetration_impulse = positional_error * jac0;
  const btScalar velocity_impulse = velocity_error * jac0;
  if (!info.m_splitImpulse || penetration > info.m_splitImpulsePenetrationThreshold) {
    c.m_rhs = penetration_impulse + velocity_impulse;
    c.m_rhsPenetration = 0.f;
  } else {
    c.m_rhs = velocity_impulse;
    c.m_rhsPenetration = penetration_impulse;
  }
  c.m_cfm = cfm * jac0;
  c.m_lowerLimit = 0;
  c.m_upperLimit = 1e10f;
}

// The friction rows' scalars (setupFrictionConstraint after the vectors):
// lane k + 1 of jac and rel_vel is friction row k's.
template <int Rows>
void friction_rows(btSolverConstraint* const* row, const L4& jac, const L4& rel_vel, const FrictionAxes& axes,
                   int id_a, int id_b, const btManifoldPoint& cp) {
  for (int k = 0; k + 1 < Rows; ++k) {
    const int l = k + 1;
    btSolverConstraint& f = *row[l];
    f.m_solverBodyIdA = id_a;
    f.m_solverBodyIdB = id_b;
    f.m_friction = cp.m_combinedFriction;
    f.m_originalContactPoint = nullptr;
    f.m_appliedImpulse = 0.f;
    f.m_appliedPushImpulse = 0.f;
    f.m_jacDiagABInv = jac[l];
    const btScalar velocity_error = axes.motion[k] - rel_vel[l];
    const btScalar velocity_impulse = velocity_error * jac[l];
    const btScalar penetration_impulse = btScalar(0);
    f.m_rhs = penetration_impulse + velocity_impulse;
    f.m_rhsPenetration = 0.f;
    f.m_cfm = axes.cfm[k];
    f.m_lowerLimit = -f.m_friction;
    f.m_upperLimit = f.m_friction;
  }
}

// The fields of one side of a row.
struct SideFields {
  btVector3 btSolverConstraint::*normal;
  btVector3 btSolverConstraint::*relpos_cross_normal;
  btVector3 btSolverConstraint::*angular_component;
};
constexpr SideFields kSideA = {&btSolverConstraint::m_contactNormal1, &btSolverConstraint::m_relpos1CrossNormal,
                               &btSolverConstraint::m_angularComponentA};
constexpr SideFields kSideB = {&btSolverConstraint::m_contactNormal2, &btSolverConstraint::m_relpos2CrossNormal,
                               &btSolverConstraint::m_angularComponentB};

// One side of every lane's row: its contact normal (`normal`), relpos x
// normal (`torque`), angular component (the inverse inertia tensor times
// the torque times the angular factor), its part of the denominator (the
// axis dotted with the angular component, negated on side B, crossed with
// rel_pos) and of the relative velocity. The contact row dots the body's
// velocities plus its external impulses, a friction row linear velocity
// plus external force impulse and angular velocity alone. Without a body
// (`rb` null): zero vectors, a zero denominator part, and the contact row
// dots zero normals with the velocities plus zero, a friction row zero
// with zero.
template <int Rows>
void side(const btRigidBody* rb, const btSolverBody& body, const Vec& axis, const Vec& normal, const Vec& torque,
          const btVector3& rel_pos, bool minus_angular, const SideFields& f, btSolverConstraint* const* row,
          L4& denom, L4& vel) {
  const btVector3 zero3(0, 0, 0);
  if (!rb) {
    const L4 zero4 = {0, 0, 0, 0};
    const Vec zero_vec = {zero4, zero4, zero4};
    const btVector3 lin = body.m_linearVelocity + zero3;
    const btVector3 rot = body.m_angularVelocity + zero3;
    vel = dot(zero_vec, lanes(lin, zero3, zero3, zero3)) + dot(zero_vec, lanes(rot, zero3, zero3, zero3));
    store<Rows>(zero_vec, row, f.normal);
    store<Rows>(zero_vec, row, f.relpos_cross_normal);
    store<Rows>(zero_vec, row, f.angular_component);
    return;
  }
  const Vec ang = angular(rb->getInvInertiaTensorWorld(), torque, rb->getAngularFactor());
  // vec = m_angularComponentA.cross(rel_pos1), (-m_angularComponentB).cross(rel_pos2)
  denom = rb->getInvMass() + dot(axis, cross(minus_angular ? -ang : ang, rel_pos));
  const btVector3 lin = body.m_linearVelocity + body.m_externalForceImpulse;
  const btVector3 rot = body.m_angularVelocity + body.m_externalTorqueImpulse;
  vel = dot(normal, lanes(lin, lin, lin, lin)) +
        dot(torque, lanes(rot, body.m_angularVelocity, body.m_angularVelocity, body.m_angularVelocity));
  store<Rows>(normal, row, f.normal);
  store<Rows>(torque, row, f.relpos_cross_normal);
  store<Rows>(ang, row, f.angular_component);
}

// Rows: the contact row and Rows - 1 friction rows (2 or 3).
template <int Rows>
void setup_rows(btSolverConstraint* const* row, const FrictionAxes& axes, const btSolverBody& a,
                const btSolverBody& b, int id_a, int id_b, btManifoldPoint& cp, const btVector3& rel_pos1,
                const btVector3& rel_pos2, const btContactSolverInfo& info) {
  const btRigidBody* rb0 = a.m_originalBody;
  const btRigidBody* rb1 = b.m_originalBody;
  const btVector3& n = cp.m_normalWorldOnB;
  const btVector3& f1 = axes.axis[0];
  const btVector3& f2 = Rows > 2 ? axes.axis[1] : f1;
  const L4 zero4 = {0, 0, 0, 0};
  const Vec zero_vec = {zero4, zero4, zero4};

  // Each lane's normalAxis: contactNormal1 of a body A with mass, and what
  // the denominators dot with.
  const Vec axis = lanes(n, f1, f2, f2);

  // Side A: relpos1CrossNormal = rel_pos1.cross(normal). Side B: the
  // contact row crosses rel_pos2 with n and negates (-torqueAxis1), a
  // friction row crosses it with contactNormal2 = -normalAxis.
  L4 denom0 = zero4, vel1 = zero4, denom1 = zero4, vel2 = zero4;
  const Vec torque_a = rb0 ? cross(rel_pos1, axis) : zero_vec;
  side<Rows>(rb0, a, axis, axis, torque_a, rel_pos1, false, kSideA, row, denom0, vel1);
  Vec torque_b = zero_vec;
  if (rb1) {
    torque_b = cross(rel_pos2, lanes(n, -f1, -f2, -f2));
    torque_b.x[0] = -torque_b.x[0];
    torque_b.y[0] = -torque_b.y[0];
    torque_b.z[0] = -torque_b.z[0];
  }
  side<Rows>(rb1, b, axis, -axis, torque_b, rel_pos2, true, kSideB, row, denom1, vel2);
  const L4 rel_vel = vel1 + vel2;  // vel1Dotn + vel2Dotn

  const L4 denom = denom0 + denom1;
  contact_row(*row[0], denom[0], rel_vel[0], a, b, id_a, id_b, cp, rel_pos1, rel_pos2, info);
  // setupContactConstraint's relaxation, which the friction rows take.
  friction_rows<Rows>(row, info.m_sor / denom, rel_vel, axes, id_a, id_b, cp);
}

}  // namespace

void setup_point_rows(btSolverConstraint& contact, btSolverConstraint* const* friction, const FrictionAxes& axes,
                      const btSolverBody& a, const btSolverBody& b, int id_a, int id_b, btManifoldPoint& cp,
                      const btVector3& rel_pos1, const btVector3& rel_pos2, const btContactSolverInfo& info) {
  btSolverConstraint* const row[3] = {&contact, axes.count > 0 ? friction[0] : nullptr,
                                      axes.count > 1 ? friction[1] : nullptr};
  if (axes.count == 2)
    setup_rows<3>(row, axes, a, b, id_a, id_b, cp, rel_pos1, rel_pos2, info);
  else
    setup_rows<2>(row, axes, a, b, id_a, id_b, cp, rel_pos1, rel_pos2, info);
}

}  // namespace soda
