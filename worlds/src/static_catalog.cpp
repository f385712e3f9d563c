// StaticCatalog (static_catalog.h): the fixed statics by id, each with its
// state as a world holds it and a box bounding its Bullet AABB.
#include "static_catalog.h"

#include <algorithm>
#include <cmath>

#include <btBulletDynamicsCommon.h>

#include "body_factory.h"
#include "soda/worlds/bullet_bodies.h"

namespace soda {
namespace {

// Beyond the rotated local box: Bullet's collision margin and contact
// breaking threshold (a few cm at most) and the rounding of a float build.
constexpr double kAbsoluteSlack = 0.25;
constexpr double kRelativeSlack = 1e-4;

}  // namespace

StaticCatalog::StaticCatalog(std::vector<Body> statics) : bodies_(std::move(statics)) {
  std::sort(bodies_.begin(), bodies_.end(), [](const Body& a, const Body& b) { return a.id < b.id; });
  // A static body's state does not depend on its shape (no inertia): a
  // stand-in shape spares building a mesh's tree here.
  btSphereShape stand_in(1);
  states_.reserve(bodies_.size());
  lo_.reserve(bodies_.size());
  hi_.reserve(bodies_.size());
  for (const Body& b : bodies_) {
    std::unique_ptr<btRigidBody> rb = make_rigid_body(b, stand_in);
    if (rb->isStaticObject()) rb->setActivationState(ISLAND_SLEEPING);  // as addRigidBody does
    states_.push_back(read_dynamic_state(*rb));
    const Vec3 h = b.aabb_half_extents();
    const Vec3 slack = Vec3::Constant(kAbsoluteSlack) + kRelativeSlack * (h + b.position.cwiseAbs());
    lo_.push_back(b.position - h - slack);
    hi_.push_back(b.position + h + slack);
  }
}

std::size_t StaticCatalog::find(BodyId id) const {
  auto it = std::lower_bound(bodies_.begin(), bodies_.end(), id, [](const Body& b, BodyId i) { return b.id < i; });
  return it != bodies_.end() && it->id == id ? static_cast<std::size_t>(it - bodies_.begin()) : bodies_.size();
}

CellBox StaticCatalog::cells(std::size_t i, const UniformGrid& grid, const CellBox& box) const {
  if (!lo_[i].allFinite() || !hi_[i].allFinite()) return box;  // everywhere
  return clamp_cells(grid.cells_overlapping(lo_[i], hi_[i]), box);
}

CellBox clamp_cells(const CellBox& cells, const CellBox& box) { return {box.clamp(cells.lo), box.clamp(cells.hi)}; }

}  // namespace soda
