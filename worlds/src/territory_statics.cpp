// TerritoryWorld::Statics (territory_world_parts.h): which fixed statics a
// territory world holds, loaded by cells (static_catalog.h).
#include <algorithm>

#include "body_factory.h"
#include "soda/worlds/bullet_bodies.h"
#include "territory_world_parts.h"

namespace soda {
namespace {

bool bit(const std::vector<std::uint64_t>& bits, std::size_t i) { return (bits[i / 64] >> (i % 64)) & 1; }
void set_bit(std::vector<std::uint64_t>& bits, std::size_t i) { bits[i / 64] |= std::uint64_t{1} << (i % 64); }

bool intersect(const CellBox& a, const CellBox& b) {
  return a.lo.x <= b.hi.x && b.lo.x <= a.hi.x && a.lo.y <= b.hi.y && b.lo.y <= a.hi.y && a.lo.z <= b.hi.z &&
         b.lo.z <= a.hi.z;
}

template <class F>
bool any_cell(const CellBox& c, F&& f) {
  for (int x = c.lo.x; x <= c.hi.x; ++x)
    for (int y = c.lo.y; y <= c.hi.y; ++y)
      for (int z = c.lo.z; z <= c.hi.z; ++z)
        if (f(CellCoord{x, y, z})) return true;
  return false;
}

// Sets the bits of the cells of `c`, a range inside `box`.
void mark_cells(std::vector<std::uint64_t>& bits, const CellBox& box, const CellBox& c) {
  any_cell(c, [&](const CellCoord& cell) {
    set_bit(bits, box.index(cell));
    return false;
  });
}

}  // namespace

void TerritoryWorld::Statics::init(std::shared_ptr<const StaticCatalog> c) {
  catalog = std::move(c);
  held.assign(catalog->size(), 0);
  loaded.assign(static_cast<std::size_t>((world->map_.box().count() + 63) / 64), 0);
}

void TerritoryWorld::Statics::load_own_cells() {
  own_cells_loaded = true;
  const std::uint64_t loaded_before = world->counters_.statics_loaded;  // counts only what comes later
  const TerritoryMap& map = world->map_;
  const CellBox& box = map.box();
  for (const CellCoord& own : map.cells_of(world->id_))
    mark_cells(loaded, box, clamp_cells(CellBox{own, own}.grown(map.reach()), box));
  for (std::size_t i = 0; i < catalog->size(); ++i)
    if (any_cell(catalog->cells(i, map.grid(), box), [&](const CellCoord& c) { return bit(loaded, box.index(c)); }))
      hold_index(i);
  world->counters_.statics_loaded = loaded_before;
}

bool TerritoryWorld::Statics::all_loaded(const CellBox& c) const {
  const CellBox& box = world->map_.box();
  return !any_cell(c, [&](const CellCoord& cell) { return !bit(loaded, box.index(cell)); });
}

void TerritoryWorld::Statics::load_slow(const CellBox& c) {
  const TerritoryMap& map = world->map_;
  for (std::size_t i = 0; i < catalog->size(); ++i)
    if (!held[i] && intersect(catalog->cells(i, map.grid(), map.box()), c)) hold_index(i);
  mark_cells(loaded, map.box(), c);
}

void TerritoryWorld::Statics::hold_index(std::size_t i) {
  if (held[i]) return;
  held[i] = 1;
  ++held_count;
  ++world->counters_.statics_loaded;
  world->insert_static(catalog->body(i));
}

void TerritoryWorld::Statics::hold(BodyId id) {
  if (const std::size_t i = catalog->find(id); i != catalog->size()) hold_index(i);
}

btCollisionObject* TerritoryWorld::Statics::object(BodyId id) {
  if (auto it = world->entries_.find(id); it != world->entries_.end())
    return it->second->role == Role::Static ? it->second->body.get() : nullptr;
  const std::size_t i = catalog->find(id);
  if (i == catalog->size()) return nullptr;
  Detached& d = detached[id];
  if (!d.body) {
    ++world->counters_.static_copies;
    d.shape = make_collision_shape(catalog->body(i).shape);
    d.body = make_body_from_state(catalog->body(i), *d.shape, catalog->state(i));  // the state a held one has
    d.body->forceActivationState(catalog->state(i).activation_state);
  }
  return d.body.get();
}

bool TerritoryWorld::Statics::is_static(BodyId id) const {
  if (catalog->find(id) != catalog->size()) return true;
  auto it = world->entries_.find(id);
  return it != world->entries_.end() && it->second->role == Role::Static;  // a kinematic body
}

}  // namespace soda
