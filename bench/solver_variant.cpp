// Solver variants for diagnosis (solver_variant.h).
#include "soda/bench/solver_variant.h"

#include <sstream>
#include <stdexcept>

#include <BulletDynamics/ConstraintSolver/btNNCGConstraintSolver.h>
#include <BulletDynamics/MLCPSolvers/btDantzigSolver.h>
#include <BulletDynamics/MLCPSolvers/btMLCPSolver.h>
#include <btBulletDynamicsCommon.h>

namespace soda {

void apply_solver_variant(btDiscreteDynamicsWorld& world, const std::string& variant,
                          std::unique_ptr<btConstraintSolver>& solver_out) {
  btContactSolverInfo& info = world.getSolverInfo();
  std::stringstream list(variant);
  std::string item;
  while (std::getline(list, item, ',')) {
    if (item.empty()) continue;
    const auto eq = item.find('=');
    const std::string key = item.substr(0, eq);
    const double v = eq == std::string::npos ? 0.0 : std::stod(item.substr(eq + 1));
    auto each_body = [&](auto&& f) {
      for (int i = 0; i < world.getNumCollisionObjects(); ++i) f(*world.getCollisionObjectArray()[i]);
    };
    if (key == "ws") info.m_warmstartingFactor = btScalar(v);
    else if (key == "nows") info.m_solverMode &= ~SOLVER_USE_WARMSTARTING;
    else if (key == "split") info.m_splitImpulse = v != 0.0;
    else if (key == "erp") info.m_erp = btScalar(v);
    else if (key == "erp2") info.m_erp2 = btScalar(v);
    else if (key == "spthr") info.m_splitImpulsePenetrationThreshold = btScalar(v);
    else if (key == "sor") info.m_sor = btScalar(v);
    else if (key == "slop") info.m_linearSlop = btScalar(v);
    else if (key == "fdir") info.m_solverMode |= SOLVER_USE_2_FRICTION_DIRECTIONS | SOLVER_ENABLE_FRICTION_DIRECTION_CACHING;
    else if (key == "interleave") info.m_solverMode |= SOLVER_INTERLEAVE_CONTACT_AND_FRICTION_CONSTRAINTS;
    else if (key == "novdf") info.m_solverMode |= SOLVER_DISABLE_VELOCITY_DEPENDENT_FRICTION_DIRECTION;
    else if (key == "fdir1") info.m_solverMode |= SOLVER_ENABLE_FRICTION_DIRECTION_CACHING;
    else if (key == "it") info.m_numIterations = static_cast<int>(v);
    else if (key == "rand") info.m_solverMode |= SOLVER_RANDMIZE_ORDER;
    else if (key == "cpt") each_body([&](btCollisionObject& o) { o.setContactProcessingThreshold(btScalar(v)); });
    else if (key == "fric") each_body([&](btCollisionObject& o) { o.setFriction(btScalar(v)); });
    else if (key == "nosleep")
      each_body([&](btCollisionObject& o) {
        if (!o.isStaticObject()) o.forceActivationState(DISABLE_DEACTIVATION);
      });
    else if (key == "nncg") {
      solver_out = std::make_unique<btNNCGConstraintSolver>();
      world.setConstraintSolver(solver_out.get());
    } else if (key == "mlcp") {
      static btDantzigSolver dantzig;  // stateless between solves; diagnosis only
      solver_out = std::make_unique<btMLCPSolver>(&dantzig);
      world.setConstraintSolver(solver_out.get());
    } else {
      throw std::invalid_argument("--variant: unknown key '" + key + "'");
    }
  }
}

}  // namespace soda
