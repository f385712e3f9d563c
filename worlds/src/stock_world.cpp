#include "soda/worlds/stock_world.h"

namespace soda {

StockWorld::StockWorld(const Scene& scene, const std::vector<std::size_t>& insertion_order)
    : settings_(scene.settings),
      config_(std::make_unique<btDefaultCollisionConfiguration>()),
      dispatcher_(std::make_unique<btCollisionDispatcher>(config_.get())),
      broadphase_(std::make_unique<btDbvtBroadphase>()),
      solver_(std::make_unique<btSequentialImpulseConstraintSolver>()),
      world_(std::make_unique<btDiscreteDynamicsWorld>(dispatcher_.get(), broadphase_.get(),
                                                       solver_.get(), config_.get())),
      bodies_(scene) {
  world_->setGravity(to_bt(settings_.gravity));
  world_->getSolverInfo().m_numIterations = settings_.iterations;
  if (insertion_order.empty()) {
    for (auto& b : bodies_.bodies) world_->addRigidBody(b.get());
  } else {
    for (std::size_t i : insertion_order) world_->addRigidBody(bodies_.bodies.at(i).get());
  }
}

StockWorld::~StockWorld() {
  for (int i = world_->getNumCollisionObjects() - 1; i >= 0; --i)
    world_->removeCollisionObject(world_->getCollisionObjectArray()[i]);
}

void StockWorld::step() {
  // maxSubSteps = 0: exactly one internal step of h per call, no time
  // accumulator whose rounding could drop or add a substep.
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  for (int i = 0; i < settings_.substeps; ++i) world_->stepSimulation(h, 0, h);
  ++steps_done_;
}

std::vector<BodyState> StockWorld::body_states() const {
  std::vector<BodyState> out;
  out.reserve(bodies_.bodies.size());
  for (const auto& b : bodies_.bodies) out.push_back(read_body_state(*b));
  return out;
}

std::uint64_t StockWorld::state_hash() const { return soda::state_hash(body_states()); }

std::size_t StockWorld::body_count() const { return bodies_.bodies.size(); }

std::size_t StockWorld::sleeping_count() const {
  std::size_t n = 0;
  for (const auto& b : bodies_.bodies)
    if (!b->isStaticObject() && b->getActivationState() == ISLAND_SLEEPING) ++n;  // statics sleep too in Bullet
  return n;
}

}  // namespace soda
