// TerritoryWorld, parking (docs/skip.md; the mechanics and why they are
// exact: parking.h). What a territory world adds to the canonical world's
// rules:
//  1. only islands solved in place here are parked, and only if no body of
//     theirs was sent as a ghost this step (its halo lies inside this
//     world's cells) and none keeps contact state here for a pair held
//     elsewhere: a settled body does not move, so such an island is no
//     neighbour's business until something moves into it, and no message of
//     any neighbour names it;
//  2. the wake rule's active bodies are the owned bodies in the world and the
//     ghosts: a neighbour's body reaching into this world's cells arrives as
//     a ghost before collide(), so it wakes what it touches as an owned body
//     would;
//  3. a parked body stays owned: snapshots, readouts and the load views
//     count it, and an input naming it brings its island back first (at the
//     step boundary the input applies at, where the unparked run has the
//     island, settled, in the world).
#include <algorithm>
#include <stdexcept>
#include <string>
#include <unordered_set>

#include "canonical_dynamics_world.h"
#include "soda/worlds/bullet_bodies.h"
#include "settled.h"
#include "territory_world_parts.h"

namespace soda {
namespace {

// An owned body now parked in `slot`, at the end of the world's parked list.
void mark_parked(TerritoryWorld::Entry& e, std::size_t slot, std::vector<TerritoryWorld::Entry*>& parked) {
  e.parked = true;
  e.parked_slot = slot;
  e.parked_index = parked.size();
  parked.push_back(&e);
}

}  // namespace

void TerritoryWorld::set_parking(bool on) {
  if (on == parking_) return;
  parking_ = on;
  if (on) {
    park_lone_settled();
  } else {
    parts_->parking.unpark_all();
    sort_lists();
  }
}

// The cells of the body's AABB (as updateSingleAabb computes it) are all
// this world's: no neighbour gets it as a ghost while it does not move.
bool TerritoryWorld::inside_own_cells(const Entry& e) const {
  btVector3 lo, hi;
  bullet_aabb(*e.body, lo, hi);
  const Vec3 l(double(lo.x()), double(lo.y()), double(lo.z())), h(double(hi.x()), double(hi.y()), double(hi.z()));
  if (!l.allFinite() || !h.allFinite()) return false;
  const CellBox cells = map_.grid().cells_overlapping(l, h);
  for (int x = cells.lo.x; x <= cells.hi.x; ++x)
    for (int y = cells.lo.y; y <= cells.hi.y; ++y)
      for (int z = cells.lo.z; z <= cells.hi.z; ++z)
        if (map_.owner(CellCoord{x, y, z}) != id_) return false;
  return true;
}

// A world without contact state (built from a scene): its settled bodies
// inside its cells, each its own island (canonical: park_lone_settled_bodies).
void TerritoryWorld::park_lone_settled() {
  if (gDisableDeactivation || !kept_.empty() || contacts_kept_elsewhere_) return;
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i)
    if (d.getManifoldByIndexInternal(i)->getNumContacts() > 0) return;
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  for (Entry* e : owned_) {
    if (e->joints > 0 || !body_settled(*e->body, h) || !inside_own_cells(*e)) continue;
    btCollisionObject* one[] = {e->body.get()};
    mark_parked(*e, parts_->parking.add_island(one, 1), parked_);
  }
  parts_->parking.finish_parking();
}

// End of integrate(): the settled islands of this step's local islands.
void TerritoryWorld::park_settled_islands() {
  if (!parking_ || gDisableDeactivation || local_islands_.size() == 0) return;
  const btScalar h = btScalar(settings_.dt / settings_.substeps);
  std::unordered_set<BodyId> kept_bodies;
  for (const auto& [pair, state] : kept_) kept_bodies.insert(pair.first), kept_bodies.insert(pair.second);
  std::vector<btCollisionObject*> bodies;
  bool any = false;
  for (std::size_t i = 0; i < local_islands_.size(); ++i) {
    bodies.clear();
    bool park = true;
    for (std::uint32_t j = local_islands_.begin[i]; j < local_islands_.begin[i + 1]; ++j) {
      const BodyId id = local_islands_.ids[j];
      auto it = entries_.find(id);
      park = it != entries_.end() && it->second->role == Role::Owned;
      if (!park) break;
      const Entry& e = *it->second;
      park = !e.parked && e.joints == 0 && e.sent_to.empty() && !kept_bodies.count(id) && body_settled(*e.body, h);
      if (!park) break;
      bodies.push_back(e.body.get());
    }
    if (!park) continue;
    const std::size_t slot = parts_->parking.add_island(bodies.data(), static_cast<int>(bodies.size()));
    for (btCollisionObject* o : bodies) mark_parked(entry_of(o), slot, parked_);
    any = true;
  }
  if (!any) return;
  // Their contact state: a manifold with points on a body just parked is
  // within its island or with a static body (bodies parked before are out
  // of the world, and so are their manifolds).
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    const Entry& a = entry_of(m->getBody0());
    const Entry& b = entry_of(m->getBody1());
    const Entry* p = a.parked ? &a : (b.parked ? &b : nullptr);
    if (p) parts_->parking.add_contact(p->parked_slot, *m);
  }
  parts_->parking.finish_parking();
}

// collide(), after the AABBs and before the pair pass: the wake rule.
void TerritoryWorld::wake_parked() {
  Parking& parking = parts_->parking;
  if (!parking_ || parking.parked_islands() == 0) return;
  if (gDisableDeactivation) {
    parking.touch_all();
  } else {
    for (const std::vector<Entry*>* list : {&owned_, &ghosts_})
      for (const Entry* e : *list) {
        if (!e->body->isActive()) continue;
        const btBroadphaseProxy* p = e->body->getBroadphaseHandle();
        parking.touch(p->m_aabbMin, p->m_aabbMax);
      }
    const btScalar h = btScalar(settings_.dt / settings_.substeps);
    for (const Entry* e : statics_) {
      if (!e->description.kinematic || !e->body->isActive()) continue;  // active in the steps it moves
      if (kinematic_teleported(*e->body)) {
        parking.touch_all();
        break;
      }
      btVector3 lo, hi;
      kinematic_touch_box(*e->body, h, lo, hi);
      parking.touch(lo, hi);
    }
  }
  parking.wake_touched();
  sort_lists();
}

// An input names a parked body: its island comes back, contacts included,
// at the step boundary.
void TerritoryWorld::unpark_for_input(Entry& e) {
  if (!e.parked) return;
  parts_->parking.unpark_island(e.parked_slot);
  sort_lists();
}

void TerritoryWorld::return_parked(btRigidBody* body) {
  Entry& e = entry_of(body);
  if (!e.parked) throw std::logic_error("TerritoryWorld: returning a body that is not parked");
  add_body_with_canonical_proxy(parts_->world, parts_->broadphase, body, proxy_bits(e.description.collision_group),
                                proxy_bits(e.description.collision_mask));
  Entry* last = parked_.back();
  parked_[e.parked_index] = last;
  last->parked_index = e.parked_index;
  parked_.pop_back();
  e.parked = false;
  owned_.push_back(&e);
  lists_sorted_ = false;
  quiet_ = -1;
}

void TerritoryWorld::forget_parked() {
  parts_->world.compact_detached_bodies();
  owned_.erase(std::remove_if(owned_.begin(), owned_.end(), [](const Entry* e) { return e->parked; }),
               owned_.end());  // keeps the order
  quiet_ = -1;
}

std::vector<const TerritoryWorld::Entry*> TerritoryWorld::all_owned_by_id() const {
  std::vector<const Entry*> order(owned_.begin(), owned_.end());
  order.insert(order.end(), parked_.begin(), parked_.end());
  // owned_ is sorted but for a short tail (migrants, woken bodies).
  const auto by_id = [](const Entry* a, const Entry* b) { return a->id() < b->id(); };
  const auto tail = std::is_sorted_until(order.begin(), order.end(), by_id);
  if (tail != order.end()) {
    std::sort(tail, order.end(), by_id);
    std::inplace_merge(order.begin(), tail, order.end(), by_id);
  }
  return order;
}

}  // namespace soda
