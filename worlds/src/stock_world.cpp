#include "soda/worlds/stock_world.h"

#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "joint_factory.h"
#include "collision_filter.h"
#include "soda/worlds/bullet_allocator.h"
#include "world_teardown.h"

namespace soda {
namespace {

// The first Bullet object of the world: the allocator hook goes in before it.
std::unique_ptr<btDefaultCollisionConfiguration> make_config() {
  install_bullet_allocator();
  return std::make_unique<btDefaultCollisionConfiguration>();
}

}  // namespace

StockWorld::StockWorld(const Scene& scene, const std::vector<std::size_t>& insertion_order)
    : settings_(scene.settings),
      config_(make_config()),
      dispatcher_(std::make_unique<btCollisionDispatcher>(config_.get())),
      broadphase_(std::make_unique<btDbvtBroadphase>()),
      solver_(std::make_unique<btSequentialImpulseConstraintSolver>()),
      world_(std::make_unique<btDiscreteDynamicsWorld>(dispatcher_.get(), broadphase_.get(),
                                                       solver_.get(), config_.get())),
      bodies_(scene),
      filter_(std::make_unique<BodyFilter>()) {
  // The same collision filter as SODA's worlds (collision_filter.h).
  broadphase_->getOverlappingPairCache()->setOverlapFilterCallback(filter_.get());
  const auto add = [&](std::size_t i) {
    const Body& d = scene.bodies.at(i);
    world_->addRigidBody(bodies_.bodies.at(i).get(), proxy_bits(d.collision_group), proxy_bits(d.collision_mask));
  };
  world_->setGravity(to_bt(settings_.gravity));
  world_->getSolverInfo().m_numIterations = settings_.iterations;
  try {
    if (insertion_order.empty()) {
      for (std::size_t i = 0; i < bodies_.bodies.size(); ++i) add(i);
    } else {
      for (std::size_t i : insertion_order) add(i);
    }
    std::unordered_map<BodyId, btRigidBody*> by_id;
    for (std::size_t i = 0; i < scene.bodies.size(); ++i) by_id[scene.bodies[i].id] = bodies_.bodies[i].get();
    std::vector<std::size_t> order(scene.joints.size());
    std::iota(order.begin(), order.end(), std::size_t{0});
    std::sort(order.begin(), order.end(),
              [&](std::size_t x, std::size_t y) { return scene.joints[x].id < scene.joints[y].id; });
    for (std::size_t i : order) {
      const Joint& j = scene.joints[i];
      auto a = by_id.find(j.body_a), b = by_id.find(j.body_b);
      if (a == by_id.end() || b == by_id.end())
        throw std::invalid_argument("StockWorld: joint " + std::to_string(j.id) + " joins a body not in the scene");
      joints_.push_back(make_constraint(j, *a->second, *b->second));
      world_->addConstraint(joints_.back().get(), !j.collide_connected);
    }
  } catch (...) {  // e.g. std::bad_alloc: the world goes before the bodies it reads
    release_all_pairs(*broadphase_, *dispatcher_);
    world_.reset();
    throw;
  }
}

// Linear in bodies (world_teardown.h): pairs first, then the world (its
// destructor reads the bodies, which bodies_ still holds), then the rest.
StockWorld::~StockWorld() {
  release_all_pairs(*broadphase_, *dispatcher_);
  world_.reset();
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
