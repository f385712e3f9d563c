// Internal: the rows of one contact point — its contact row and its one or
// two friction rows — set up together (coloured_setup.cpp), with the bits
// Bullet's setupContactConstraint and setupFrictionConstraint give them one
// at a time.
//
// Why: Bullet sets up each row in its own call, reloading the two bodies and
// recomputing what the rows share; the setup of a pile's rows was a fifth
// of the canonical step's instructions (docs/results/where-the-time-goes.md).
// Here the three rows are the lanes of one computation (lane 0 the contact
// row, lanes 1 and 2 the friction rows), which the compiler vectorises.
//
// Why the bits are Bullet's: every lane evaluates the expression Bullet's
// call for that row evaluates, operand for operand in the same order,
// signs of zero included (Bullet's contact row negates r2 x n where a
// friction row crosses r2 with -axis: both are done as Bullet does them);
// the build has no contraction into fused multiply-add (CMakeLists.txt).
// Lanes never mix. ColouredSolve.EqualsBulletsLoopInTheColourOrder and the
// state hashes hold it.
//
// Applies to a point without per-point solver parameters: no contact CFM,
// ERP, stiffness or damping, no friction anchor (point_rows_apply); such a
// point takes Bullet's own calls.
#pragma once

#include <btBulletDynamicsCommon.h>

namespace soda {

/// True if setup_point_rows gives this point's rows.
inline bool point_rows_apply(const btManifoldPoint& cp) {
  return !(cp.m_contactPointFlags & (BT_CONTACT_FLAG_HAS_CONTACT_CFM | BT_CONTACT_FLAG_HAS_CONTACT_ERP |
                                     BT_CONTACT_FLAG_CONTACT_STIFFNESS_DAMPING | BT_CONTACT_FLAG_FRICTION_ANCHOR));
}

/// The friction rows of one point: direction, target relative velocity and
/// CFM of each (Bullet's normalAxis, desiredVelocity, cfmSlip).
struct FrictionAxes {
  btVector3 axis[2];
  btScalar motion[2] = {0, 0};
  btScalar cfm[2] = {0, 0};
  int count = 0;
};

/// Sets up `contact` as setupContactConstraint does with warm starting off
/// (applied impulse 0; the caller warm-starts), and friction[k] as
/// setupFrictionConstraint does for axes.axis[k] (k < axes.count), with the
/// contact row's relaxation. a, b: the solver bodies at ids id_a, id_b.
/// Writes the fields those calls write, no others (the frictions' and the
/// contact's m_frictionIndex are the caller's).
void setup_point_rows(btSolverConstraint& contact, btSolverConstraint* const* friction, const FrictionAxes& axes,
                      const btSolverBody& a, const btSolverBody& b, int id_a, int id_b, btManifoldPoint& cp,
                      const btVector3& rel_pos1, const btVector3& rel_pos2, const btContactSolverInfo& info);

}  // namespace soda
