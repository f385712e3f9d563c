// ColouredSolver's setup and finish on the pool (docs/coloured-solve.md,
// "The rest of the step on the pool"). convertContacts: Bullet's contact and
// friction rows of every island, built in three steps (on the pool's threads
// for a large island, on the calling thread otherwise). The rows, their
// indices and the solver bodies' warm-start deltas are the bits Bullet's
// serial convertContacts gives:
//
//  1. on the calling thread, in manifold order: each manifold's two solver
//     bodies (getOrInitSolverBody: it may append the fixed body or a
//     kinematic body, so its calls keep Bullet's order), whether Bullet
//     skips it (two bodies without mass) and how many of its points become
//     rows (distance <= the manifold's processing threshold). Prefix sums
//     give each manifold its first contact row; every contact row has
//     exactly frictions_per_contact friction rows right after the previous
//     contact's (one, or two with SOLVER_USE_2_FRICTION_DIRECTIONS, in every
//     branch of Bullet's friction setup), so its friction rows' indices are
//     known as well;
//  2. on the pool, per manifold: its rows at those indices, a point's
//     contact and friction rows set up together (point_rows.h: Bullet's
//     setupContactConstraint and setupFrictionConstraint, three rows at
//     once), or by Bullet's own calls for a point with its own solver
//     parameters (contact CFM, ERP, stiffness, friction anchor). Each manifold writes
//     only its own rows and its own points (the friction directions); the
//     solver bodies are only read (their velocities, never their deltas).
//     Warm starting is left out here (setupContactConstraint called with
//     SOLVER_USE_WARMSTARTING cleared);
//  3. on the calling thread, in row order: the warm start, as
//     setupContactConstraint does it (the row's impulse from its point,
//     applied to both solver bodies' deltas). It is the only part that adds
//     into shared state, and it adds in Bullet's order.
// convertBodies likewise: when every body of the island is dynamic (mass,
// not kinematic: each one gets the next solver body in Bullet's loop, so
// body i gets solver body i), the solver bodies are initialised on the pool,
// each by Bullet's initSolverBody plus Bullet's gyroscopic terms.
// solveGroupCacheFriendlyFinish likewise: Bullet's writeBackContacts and
// writeBackBodies on ranges of rows and bodies (each writes its row's own
// contact point or its solver body's own rigid body), on the pool.
// Rolling friction (a third pool whose row count depends on the contact's
// geometry) takes Bullet's serial convertContacts; small islands and a pool
// of one thread take Bullet's convertBodies and finish.
#include <algorithm>
#include <atomic>

#include "coloured_solver.h"
#include "parallel_stages.h"
#include "point_rows.h"

namespace soda {

namespace {
std::atomic<bool> point_rows_allowed{true};
}  // namespace

void ColouredSolver::allow_point_rows(bool allow) { point_rows_allowed.store(allow); }

void ColouredSolver::convertBodies(btCollisionObject** bodies, int count, const btContactSolverInfo& info) {
  SolverPool* pool = pool_ && pool_->threads() > 1 ? pool_.get() : nullptr;
  bool dynamic = pool && count >= kParallelMinSolverBodies;
  for (int i = 0; dynamic && i < count; ++i) {
    const btRigidBody* rb = btRigidBody::upcast(bodies[i]);
    dynamic = rb && !rb->isStaticOrKinematicObject() && rb->getInvMass() != 0;
  }
  if (!dynamic) {
    btSequentialImpulseConstraintSolver::convertBodies(bodies, count, info);
    return;
  }
  // Bullet's bookkeeping of an empty island (its kinematic table cleared),
  // then body i -> solver body i.
  btSequentialImpulseConstraintSolver::convertBodies(bodies, 0, info);
  m_tmpSolverBodyPool.reserve(count + 1);
  m_tmpSolverBodyPool.resizeNoInitialize(count);
  const btScalar dt = info.m_timeStep;
  const int threads =
      run_in_chunks(pool, count, kParallelMinSolverBodies, kSolverBodiesPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      btRigidBody* body = btRigidBody::upcast(bodies[i]);
      btSolverBody& solver_body = m_tmpSolverBodyPool[i];
      initSolverBody(&solver_body, body, dt);
      body->setCompanionId(i);
      if (body->getFlags() & BT_ENABLE_GYROSCOPIC_FORCE_EXPLICIT)
        solver_body.m_externalTorqueImpulse -=
            body->computeGyroscopicForceExplicit(info.m_maxGyroscopicForce) * body->getInvInertiaTensorWorld() * dt;
      if (body->getFlags() & BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_WORLD)
        solver_body.m_externalTorqueImpulse += body->computeGyroscopicImpulseImplicit_World(dt);
      if (body->getFlags() & BT_ENABLE_GYROSCOPIC_FORCE_IMPLICIT_BODY)
        solver_body.m_externalTorqueImpulse += body->computeGyroscopicImpulseImplicit_Body(dt);
    }
  });
  stats_.body_setup_threads_max = std::max(stats_.body_setup_threads_max, threads);
}

void ColouredSolver::convertContacts(btPersistentManifold** manifolds, int count, const btContactSolverInfo& info) {
  SolverPool* pool = pool_ && pool_->threads() > 1 ? pool_.get() : nullptr;
  const bool together = point_rows_allowed.load(std::memory_order_relaxed);
  if (!pool && !together) {  // the tests' reference: Bullet's own loop
    btSequentialImpulseConstraintSolver::convertContacts(manifolds, count, info);
    return;
  }
  // Step 1.
  manifold_rows_.resize(static_cast<std::size_t>(count));
  const int contact_base = m_tmpSolverContactConstraintPool.size();
  int contacts = contact_base;
  for (int i = 0; i < count; ++i) {
    btPersistentManifold* m = manifolds[i];
    ManifoldRows& rows = manifold_rows_[static_cast<std::size_t>(i)];
    rows.body_a = getOrInitSolverBody(*const_cast<btCollisionObject*>(m->getBody0()), info.m_timeStep);
    rows.body_b = getOrInitSolverBody(*const_cast<btCollisionObject*>(m->getBody1()), info.m_timeStep);
    rows.first_contact = contacts;
    rows.contacts = 0;
    if (m_tmpSolverBodyPool[rows.body_a].m_invMass.fuzzyZero() &&
        m_tmpSolverBodyPool[rows.body_b].m_invMass.fuzzyZero())
      continue;  // Bullet skips a pair of bodies without mass
    for (int j = 0; j < m->getNumContacts(); ++j) {
      const btManifoldPoint& cp = m->getContactPoint(j);
      if (cp.getDistance() > m->getContactProcessingThreshold()) continue;
      if (cp.m_combinedRollingFriction > 0) {
        // Bullet's loop; its getOrInitSolverBody calls find the bodies made
        // above (the same indices, made in the same order).
        btSequentialImpulseConstraintSolver::convertContacts(manifolds, count, info);
        return;
      }
      ++rows.contacts;
      if (together && point_rows_apply(cp)) ++stats_.point_rows;
    }
    contacts += rows.contacts;
  }
  const int frictions_per_contact = (info.m_solverMode & SOLVER_USE_2_FRICTION_DIRECTIONS) ? 2 : 1;
  const int friction_base = m_tmpSolverContactFrictionConstraintPool.size();
  m_tmpSolverContactConstraintPool.resizeNoInitialize(contacts);
  m_tmpSolverContactFrictionConstraintPool.resizeNoInitialize(friction_base +
                                                              (contacts - contact_base) * frictions_per_contact);

  // Step 2.
  btContactSolverInfo cold = info;
  cold.m_solverMode &= ~SOLVER_USE_WARMSTARTING;
  const int threads =
      run_in_chunks(pool, count, kParallelMinManifolds, kManifoldsPerTask, [&](int begin, int end) {
        for (int i = begin; i < end; ++i) {
          const ManifoldRows& rows = manifold_rows_[static_cast<std::size_t>(i)];
          const int first_friction = friction_base + (rows.first_contact - contact_base) * frictions_per_contact;
          convert_manifold(*manifolds[i], rows, first_friction, frictions_per_contact, together, cold);
        }
      });
  if (pool) stats_.setup_threads_max = std::max(stats_.setup_threads_max, threads);

  // Step 3.
  if (!(info.m_solverMode & SOLVER_USE_WARMSTARTING)) return;
  for (int r = contact_base; r < contacts; ++r) {
    btSolverConstraint& c = m_tmpSolverContactConstraintPool[r];
    const btManifoldPoint& cp = *static_cast<const btManifoldPoint*>(c.m_originalContactPoint);
    btSolverBody& a = m_tmpSolverBodyPool[c.m_solverBodyIdA];
    btSolverBody& b = m_tmpSolverBodyPool[c.m_solverBodyIdB];
    c.m_appliedImpulse = cp.m_appliedImpulse * info.m_warmstartingFactor;
    if (a.m_originalBody)
      a.internalApplyImpulse(c.m_contactNormal1 * a.internalGetInvMass(), c.m_angularComponentA, c.m_appliedImpulse);
    if (b.m_originalBody)
      b.internalApplyImpulse(-c.m_contactNormal2 * b.internalGetInvMass(), -c.m_angularComponentB,
                             -(btScalar)c.m_appliedImpulse);
  }
}

// One manifold's rows (step 2), in the order and with the calls of
// btSequentialImpulseConstraintSolver::convertContact, at the indices step 1
// gave it instead of appended.
void ColouredSolver::convert_manifold(btPersistentManifold& m, const ManifoldRows& rows, int first_friction,
                                      int frictions_per_contact, bool together, const btContactSolverInfo& info) {
  if (rows.contacts == 0) return;
  auto* obj0 = const_cast<btCollisionObject*>(m.getBody0());
  auto* obj1 = const_cast<btCollisionObject*>(m.getBody1());
  const int a = rows.body_a, b = rows.body_b;
  btSolverBody& body_a = m_tmpSolverBodyPool[a];
  btSolverBody& body_b = m_tmpSolverBodyPool[b];
  const bool two = frictions_per_contact == 2;
  int row = rows.first_contact, friction = first_friction;
  for (int j = 0; j < m.getNumContacts(); ++j) {
    btManifoldPoint& cp = m.getContactPoint(j);
    if (cp.getDistance() > m.getContactProcessingThreshold()) continue;
    btSolverConstraint& c = m_tmpSolverContactConstraintPool[row];
    c.m_solverBodyIdA = a;
    c.m_solverBodyIdB = b;
    c.m_originalContactPoint = &cp;
    const btVector3 rel_pos1 = cp.getPositionWorldOnA() - obj0->getWorldTransform().getOrigin();
    const btVector3 rel_pos2 = cp.getPositionWorldOnB() - obj1->getWorldTransform().getOrigin();
    c.m_frictionIndex = friction;

    // The friction directions, as Bullet's convertContact picks them (and
    // caches them in the point).
    FrictionAxes axes;
    auto add = [&](const btVector3& axis, btScalar motion, btScalar cfm) {
      axes.axis[axes.count] = axis;
      axes.motion[axes.count] = motion;
      axes.cfm[axes.count] = cfm;
      ++axes.count;
    };
    auto anisotropic = [&](btVector3& dir) {
      applyAnisotropicFriction(obj0, dir, btCollisionObject::CF_ANISOTROPIC_FRICTION);
      applyAnisotropicFriction(obj1, dir, btCollisionObject::CF_ANISOTROPIC_FRICTION);
    };
    if (!(info.m_solverMode & SOLVER_ENABLE_FRICTION_DIRECTION_CACHING) ||
        !(cp.m_contactPointFlags & BT_CONTACT_FLAG_LATERAL_FRICTION_INITIALIZED)) {
      btVector3 vel1, vel2;  // (Bullet computes them for every point; only new directions read them)
      body_a.getVelocityInLocalPointNoDelta(rel_pos1, vel1);
      body_b.getVelocityInLocalPointNoDelta(rel_pos2, vel2);
      const btVector3 vel = vel1 - vel2;
      const btScalar rel_vel = cp.m_normalWorldOnB.dot(vel);
      cp.m_lateralFrictionDir1 = vel - cp.m_normalWorldOnB * rel_vel;
      const btScalar lat_rel_vel = cp.m_lateralFrictionDir1.length2();
      if (!(info.m_solverMode & SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION) && lat_rel_vel > SIMD_EPSILON) {
        cp.m_lateralFrictionDir1 *= 1.f / btSqrt(lat_rel_vel);
        anisotropic(cp.m_lateralFrictionDir1);
        add(cp.m_lateralFrictionDir1, 0, 0);
        if (two) {
          cp.m_lateralFrictionDir2 = cp.m_lateralFrictionDir1.cross(cp.m_normalWorldOnB);
          cp.m_lateralFrictionDir2.normalize();
          anisotropic(cp.m_lateralFrictionDir2);
          add(cp.m_lateralFrictionDir2, 0, 0);
        }
      } else {
        btPlaneSpace1(cp.m_normalWorldOnB, cp.m_lateralFrictionDir1, cp.m_lateralFrictionDir2);
        anisotropic(cp.m_lateralFrictionDir1);
        add(cp.m_lateralFrictionDir1, 0, 0);
        if (two) {
          anisotropic(cp.m_lateralFrictionDir2);
          add(cp.m_lateralFrictionDir2, 0, 0);
          if (info.m_solverMode & SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION)
            cp.m_contactPointFlags |= BT_CONTACT_FLAG_LATERAL_FRICTION_INITIALIZED;
        }
      }
    } else {
      add(cp.m_lateralFrictionDir1, cp.m_contactMotion1, cp.m_frictionCFM);
      if (two) add(cp.m_lateralFrictionDir2, cp.m_contactMotion2, cp.m_frictionCFM);
    }

    // The rows: the contact row, then its friction rows, each friction row
    // pointing back at the contact row.
    btSolverConstraint* frictions[2];
    for (int k = 0; k < axes.count; ++k) {
      frictions[k] = &m_tmpSolverContactFrictionConstraintPool[friction + k];
      frictions[k]->m_frictionIndex = row;
    }
    if (together && point_rows_apply(cp)) {
      setup_point_rows(c, frictions, axes, body_a, body_b, a, b, cp, rel_pos1, rel_pos2, info);
    } else {
      btScalar relaxation;
      setupContactConstraint(c, a, b, cp, info, relaxation, rel_pos1, rel_pos2);
      for (int k = 0; k < axes.count; ++k)
        setupFrictionConstraint(*frictions[k], axes.axis[k], a, b, cp, rel_pos1, rel_pos2, obj0, obj1, relaxation,
                                info, axes.motion[k], axes.cfm[k]);
    }
    friction += axes.count;
    setFrictionConstraintImpulse(c, a, b, cp, info);
    ++row;
  }
}

btScalar ColouredSolver::solveGroupCacheFriendlyFinish(btCollisionObject** bodies, int count,
                                                       const btContactSolverInfo& info) {
  SolverPool* pool = pool_ && pool_->threads() > 1 ? pool_.get() : nullptr;
  if (!pool || m_tmpSolverNonContactConstraintPool.size() != 0)
    return btSequentialImpulseConstraintSolver::solveGroupCacheFriendlyFinish(bodies, count, info);
  int threads = 1;
  if (info.m_solverMode & SOLVER_USE_WARMSTARTING)
    threads = run_in_chunks(pool, m_tmpSolverContactConstraintPool.size(), kColouredMinContactRows,
                            kRowsPerWriteBackTask, [&](int begin, int end) { writeBackContacts(begin, end, info); });
  threads = std::max(threads, run_in_chunks(pool, m_tmpSolverBodyPool.size(), kParallelMinSolverBodies,
                                            kSolverBodiesPerTask,
                                            [&](int begin, int end) { writeBackBodies(begin, end, info); }));
  stats_.finish_threads_max = std::max(stats_.finish_threads_max, threads);
  // As Bullet's finish: the island's pools emptied.
  m_tmpSolverContactConstraintPool.resizeNoInitialize(0);
  m_tmpSolverNonContactConstraintPool.resizeNoInitialize(0);
  m_tmpSolverContactFrictionConstraintPool.resizeNoInitialize(0);
  m_tmpSolverContactRollingFrictionConstraintPool.resizeNoInitialize(0);
  m_tmpSolverBodyPool.resizeNoInitialize(0);
  return 0;
}

}  // namespace soda
