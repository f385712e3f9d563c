// Substeps per island (island_substeps.h).
#include "island_substeps.h"

#include <algorithm>
#include <vector>

#include <BulletCollision/CollisionDispatch/btCollisionObjectWrapper.h>
#include <BulletCollision/CollisionDispatch/btBoxBoxDetector.h>
#include <LinearMath/btTransformUtil.h>

#include "parallel_stages.h"
#include "speculative_contact.h"

namespace soda {
namespace {

// As btBoxBoxCollisionAlgorithm::processCollision followed by the refresh
// an algorithm owning its manifold does (Bullet's algorithms made with a
// shared manifold ignore it: box-box makes its own).
void refresh_manifold(btPersistentManifold& manifold, const btDispatcherInfo& info) {
  clear_speculative_contact(manifold);
  const btCollisionObject* a = manifold.getBody0();
  const btCollisionObject* b = manifold.getBody1();
  btCollisionObjectWrapper wa(nullptr, a->getCollisionShape(), a, a->getWorldTransform(), -1, -1);
  btCollisionObjectWrapper wb(nullptr, b->getCollisionShape(), b, b->getWorldTransform(), -1, -1);
  btManifoldResult result(&wa, &wb);
  result.setPersistentManifold(&manifold);
  btDiscreteCollisionDetectorInterface::ClosestPointInput input;
  input.m_transformA = a->getWorldTransform();
  input.m_transformB = b->getWorldTransform();
  btBoxBoxDetector detector(static_cast<const btBoxShape*>(a->getCollisionShape()),
                            static_cast<const btBoxShape*>(b->getCollisionShape()));
  detector.getClosestPoints(input, result, info.m_debugDraw);
  result.refreshContactPoints();
}

struct Saved {
  btTransform interpolation;
  btVector3 linear, angular;
};

}  // namespace

int solve_island(btConstraintSolver& solver, btCollisionObject** bodies, int body_count,
                 btPersistentManifold** manifolds, int manifold_count, const btContactSolverInfo& info,
                 int substeps, btDispatcher& dispatcher, SolverPool* pool, btTypedConstraint** constraints,
                 int constraint_count) {
  if (substeps <= 1) {
    solver.solveGroup(bodies, body_count, manifolds, manifold_count, constraints, constraint_count, info, nullptr,
                      &dispatcher);
    return 0;
  }
  int threads = 1;
  thread_local std::vector<Saved> saved;
  saved.resize(static_cast<std::size_t>(body_count));
  for (int j = 0; j < body_count; ++j) {
    const btRigidBody& rb = *btRigidBody::upcast(bodies[j]);
    saved[static_cast<std::size_t>(j)] = {rb.getInterpolationWorldTransform(), rb.getInterpolationLinearVelocity(),
                                          rb.getInterpolationAngularVelocity()};
  }
  btContactSolverInfo sub = info;
  const btScalar h = info.m_timeStep;
  sub.m_timeStep = h / btScalar(substeps);
  btDispatcherInfo dispatch_info;
  dispatch_info.m_timeStep = sub.m_timeStep;
  for (int s = 0; s < substeps; ++s) {
    if (s > 0)
      threads = std::max(threads, run_in_chunks(pool, manifold_count, kParallelMinPairs, kPairsPerTask,
                                                [&](int begin, int end) {
                                                  for (int k = begin; k < end; ++k)
                                                    refresh_manifold(*manifolds[k], dispatch_info);
                                                }));
    // The first substep warm-starts from the last step as a whole solve
    // does (info's factor); a later one from the substep just solved, with
    // the same h / substeps, in full (docs/stress.md, "The solver defaults").
    if (s == 1) sub.m_warmstartingFactor = 1;
    solver.solveGroup(bodies, body_count, manifolds, manifold_count, constraints, constraint_count, sub, nullptr,
                      &dispatcher);
    const bool last = s + 1 == substeps;
    const int integrated = run_in_chunks(pool, body_count, kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
      for (int j = begin; j < end; ++j) {
        btRigidBody& rb = *btRigidBody::upcast(bodies[j]);
        if (!rb.isActive() || rb.isStaticOrKinematicObject()) continue;
        btTransform next;
        if (!last) {
          // As btDiscreteDynamicsWorld::integrateTransforms (CCD off).
          rb.predictIntegratedTransform(sub.m_timeStep, next);
          rb.proceedToTransform(next);
        } else {
          // Rewound (header): the integrate stage's h ends the last substep.
          btTransformUtil::integrateTransform(rb.getWorldTransform(), -rb.getLinearVelocity(),
                                              -rb.getAngularVelocity(), h - sub.m_timeStep, next);
          rb.setWorldTransform(next);
        }
      }
    });
    threads = std::max(threads, integrated);
  }
  for (int j = 0; j < body_count; ++j) {
    btRigidBody& rb = *btRigidBody::upcast(bodies[j]);
    const Saved& v = saved[static_cast<std::size_t>(j)];
    rb.setInterpolationWorldTransform(v.interpolation);
    rb.setInterpolationLinearVelocity(v.linear);
    rb.setInterpolationAngularVelocity(v.angular);
    rb.updateInertiaTensor();
  }
  return threads;
}

}  // namespace soda
