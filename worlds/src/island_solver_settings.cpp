// Solver settings of the canonical step (island_solver_settings.h).
#include "island_solver_settings.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace soda {

void configure_canonical_solver(btContactSolverInfo& info, const SceneSettings& settings) {
  info.m_numIterations = settings.iterations;
  info.m_solverMode |= SOLVER_USE_2_FRICTION_DIRECTIONS | SOLVER_ENABLE_FRICTION_DIRECTION_CACHING |
                       SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION;
}

void configure_bullet_solver(btContactSolverInfo& info, const SceneSettings& settings) {
  info.m_numIterations = settings.iterations;
  info.m_solverMode &= ~(SOLVER_USE_2_FRICTION_DIRECTIONS | SOLVER_ENABLE_FRICTION_DIRECTION_CACHING |
                         SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION);
}

namespace {

using Edge = std::pair<int, int>;  // indices of two dynamic bodies; -1: a static (or kinematic) body

// The longest chain of dynamic bodies from a static one over `edges`:
// breadth-first levels from the bodies an edge joins to a static one (CSR).
int chain_height(int body_count, const std::vector<Edge>& edges) {
  thread_local std::vector<int> level, degree, adjacency, queue, cursor;
  level.assign(static_cast<std::size_t>(body_count), 0);
  degree.assign(static_cast<std::size_t>(body_count) + 1, 0);
  queue.clear();
  for (const auto& [a, b] : edges) {
    if (a >= 0 && b >= 0) {
      ++degree[static_cast<std::size_t>(a) + 1];
      ++degree[static_cast<std::size_t>(b) + 1];
    } else if (const int d = std::max(a, b); d >= 0 && level[static_cast<std::size_t>(d)] == 0) {
      level[static_cast<std::size_t>(d)] = 1;
      queue.push_back(d);
    }
  }
  if (queue.empty()) return 0;
  for (int i = 0; i < body_count; ++i) degree[static_cast<std::size_t>(i) + 1] += degree[static_cast<std::size_t>(i)];
  adjacency.resize(static_cast<std::size_t>(degree.back()));
  cursor.assign(degree.begin(), degree.end() - 1);
  for (const auto& [a, b] : edges) {
    if (a < 0 || b < 0) continue;
    adjacency[static_cast<std::size_t>(cursor[static_cast<std::size_t>(a)]++)] = b;
    adjacency[static_cast<std::size_t>(cursor[static_cast<std::size_t>(b)]++)] = a;
  }
  int height = 0;
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const int i = queue[q];
    const int next = level[static_cast<std::size_t>(i)] + 1;
    height = std::max(height, next - 1);
    for (int e = degree[static_cast<std::size_t>(i)]; e < degree[static_cast<std::size_t>(i) + 1]; ++e) {
      const int j = adjacency[static_cast<std::size_t>(e)];
      if (level[static_cast<std::size_t>(j)] == 0) {
        level[static_cast<std::size_t>(j)] = next;
        queue.push_back(j);
      }
    }
  }
  return height;
}

}  // namespace

IslandProfile profile_island(btCollisionObject* const* bodies, int body_count,
                             btPersistentManifold* const* manifolds, int manifold_count,
                             btTypedConstraint* const* joints, int joint_count) {
  IslandProfile p;
  p.bodies = body_count;
  if (manifold_count == 0 && joint_count == 0) return p;
  for (int i = 0; i < body_count; ++i) bodies[i]->setCompanionId(i);
  auto index_of = [&](const btCollisionObject* o) {
    if (o->isStaticOrKinematicObject()) return -1;
    const int i = o->getCompanionId();
    return i >= 0 && i < body_count && bodies[i] == o ? i : -2;
  };
  thread_local std::vector<Edge> edges;
  // Contacts: manifolds with points.
  edges.clear();
  for (int k = 0; k < manifold_count; ++k) {
    const btPersistentManifold* m = manifolds[k];
    if (m->getNumContacts() == 0) continue;
    if (m->getBody0()->getCollisionShape()->getShapeType() != BOX_SHAPE_PROXYTYPE ||
        m->getBody1()->getCollisionShape()->getShapeType() != BOX_SHAPE_PROXYTYPE)
      p.boxes_only = false;
    const int a = index_of(m->getBody0()), b = index_of(m->getBody1());
    if (a < -1 || b < -1 || (a == -1 && b == -1)) continue;
    edges.emplace_back(a, b);
    if (a < 0 || b < 0) continue;
    const auto* ra = static_cast<const btRigidBody*>(m->getBody0());
    const auto* rb = static_cast<const btRigidBody*>(m->getBody1());
    const btScalar ia = ra->getInvMass(), ib = rb->getInvMass();
    if (ia > 0 && ib > 0) p.mass_ratio = std::max(p.mass_ratio, double(std::max(ia / ib, ib / ia)));
    const btScalar sa = ra->getCcdSweptSphereRadius(), sb = rb->getCcdSweptSphereRadius();
    const btScalar size = btMin(sa, sb);
    if (size > 0) {
      const btScalar motion = (ra->getLinearVelocity() - rb->getLinearVelocity()).length() +
                              ra->getAngularVelocity().length() * sa + rb->getAngularVelocity().length() * sb;
      p.approach_rate = std::max(p.approach_rate, double(motion / size));
    }
  }
  p.height = chain_height(body_count, edges);
  // Joints that hold (a broken one joins nothing).
  edges.clear();
  for (int k = 0; k < joint_count; ++k) {
    const btTypedConstraint* c = joints[k];
    if (!c->isEnabled()) continue;
    const int a = index_of(&c->getRigidBodyA()), b = index_of(&c->getRigidBodyB());
    if (a < -1 || b < -1 || (a == -1 && b == -1)) continue;
    edges.emplace_back(a, b);
    if (a < 0 || b < 0) continue;
    const btScalar ia = c->getRigidBodyA().getInvMass(), ib = c->getRigidBodyB().getInvMass();
    if (ia > 0 && ib > 0) p.joint_mass_ratio = std::max(p.joint_mass_ratio, double(std::max(ia / ib, ib / ia)));
  }
  p.joint_height = chain_height(body_count, edges);
  for (int i = 0; i < body_count; ++i) bodies[i]->setCompanionId(-1);
  return p;
}

int island_iterations(int base, const IslandProfile& profile) {
  double factor = 1.0;
  if (profile.height > kPlainHeight) {
    factor = std::max(factor, std::pow(double(profile.height) / kPlainHeight, kHeightPower));
  }
  if (profile.mass_ratio > kPlainMassRatio) factor = std::max(factor, std::sqrt(profile.mass_ratio));
  if (profile.stiff() && profile.bodies <= kSmallStiffIsland)
    factor = std::min(std::sqrt(profile.mass_ratio) * profile.height, kMaxStiffFactor);
  else
    factor = std::min(factor, kMaxIterationFactor);
  return static_cast<int>(std::ceil(base * factor));
}

namespace {

bool joint_rule(const IslandProfile& profile) {
  return profile.joint_height > kJointSubstepHeight || profile.joint_mass_ratio > kJointSubstepMassRatio;
}

}  // namespace

int island_substeps(const IslandProfile& profile, double h) {
  if (!profile.boxes_only) return 1;
  if (joint_rule(profile)) return kJointSubsteps;
  return profile.approach_rate * h > kSubstepApproach ? kIslandSubsteps : 1;
}

int substep_iterations(int iterations, int substeps, const IslandProfile& profile) {
  if (substeps <= 1 || joint_rule(profile)) return iterations;
  return std::max(std::min(kMinSubstepIterations, iterations), (iterations + substeps - 1) / substeps);
}

const btContactSolverInfo& island_solver_info(const btContactSolverInfo& base, btContactSolverInfo& scratch,
                                              btCollisionObject* const* bodies, int body_count,
                                              btPersistentManifold* const* manifolds, int manifold_count,
                                              btTypedConstraint* const* joints, int joint_count, int& substeps) {
  const IslandProfile profile = profile_island(bodies, body_count, manifolds, manifold_count, joints, joint_count);
  substeps = island_substeps(profile, base.m_timeStep);
  const int iterations =
      substep_iterations(island_iterations(base.m_numIterations, profile), substeps, profile);
  const bool tall = profile.height > kPlainHeight;
  if (iterations == base.m_numIterations && !tall && !profile.stiff()) return base;
  scratch = base;
  scratch.m_numIterations = iterations;
  if (tall) scratch.m_warmstartingFactor = kTallWarmStartingFactor;
  if (profile.stiff()) scratch.m_splitImpulsePenetrationThreshold = 0;
  return scratch;
}

}  // namespace soda
