// TerritoryWorld, build_islands and solve (docs/partitioned-step.md):
//  - the contact graph of this world: owned bodies and ghosts (id order)
//    joined by the manifolds with points it holds;
//  - a component without ghosts whose owned bodies were sent to nobody is a
//    whole island: solved at once, in place, as the canonical world solves it;
//  - the others wait for the neighbours' glue; those nobody glued are whole
//    islands too; the rest are fragments of border islands, merged by the
//    runtime and solved here on copies (solve_border_island).
#include <algorithm>
#include <numeric>
#include <stdexcept>
#include <string>

#include "canonical_dynamics_world.h"
#include "soda/worlds/bullet_bodies.h"
#include "soda/worlds/value_codec.h"
#include "island_solver_settings.h"
#include "island_substeps.h"
#include "parallel_stages.h"
#include "speculative_contact.h"
#include "territory_world_parts.h"

namespace soda {
namespace {

int find(std::vector<int>& parent, int i) {
  while (parent[i] != i) {
    parent[i] = parent[parent[i]];
    i = parent[i];
  }
  return i;
}

}  // namespace

// Union-find over the nodes (dynamic bodies here, id order) joined by the
// manifolds with points; components numbered by their smallest id; nodes and
// manifolds laid out per component (CSR), manifolds by (id0, id1) inside.
void TerritoryWorld::build_islands() {
  sort_lists();
  nodes_.resize(owned_.size() + ghosts_.size());
  std::merge(owned_.begin(), owned_.end(), ghosts_.begin(), ghosts_.end(), nodes_.begin(),
             [](const Entry* a, const Entry* b) { return a->id() < b->id(); });
  for (Entry* e : statics_) e->node = -1;
  const int n = static_cast<int>(nodes_.size());
  for (int i = 0; i < n; ++i) nodes_[static_cast<std::size_t>(i)]->node = i;
  parent_.resize(static_cast<std::size_t>(n));
  std::iota(parent_.begin(), parent_.end(), 0);
  held_.clear();
  btDispatcher& d = parts_->dispatcher;
  for (int i = 0; i < d.getNumManifolds(); ++i) {
    btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;  // every manifold with points is held here (invariant 3)
    const Entry& a = entry_of(m->getBody0());
    const Entry& b = entry_of(m->getBody1());
    held_.push_back(Held{a.node >= 0 ? a.node : b.node, a.id(), b.id(), m});  // node for now
    if (a.node < 0 || b.node < 0) continue;
    const int ra = find(parent_, a.node), rb = find(parent_, b.node);
    if (ra != rb) parent_[static_cast<std::size_t>(std::max(ra, rb))] = std::min(ra, rb);  // root = smallest id
  }
  counters_.held_manifolds = held_.size();

  // Components in root (smallest id) order.
  component_of_.resize(static_cast<std::size_t>(n));
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const int r = find(parent_, i);
    component_of_[static_cast<std::size_t>(i)] = r == i ? count++ : component_of_[static_cast<std::size_t>(r)];
  }
  component_begin_.assign(static_cast<std::size_t>(count) + 1, 0);
  for (int i = 0; i < n; ++i) ++component_begin_[static_cast<std::size_t>(component_of_[static_cast<std::size_t>(i)]) + 1];
  for (int k = 0; k < count; ++k) component_begin_[static_cast<std::size_t>(k) + 1] += component_begin_[static_cast<std::size_t>(k)];
  component_objects_.resize(static_cast<std::size_t>(n));
  std::vector<int> cursor(component_begin_.begin(), component_begin_.end() - 1);
  std::vector<std::uint8_t> ghost_in(static_cast<std::size_t>(count), 0), ghosted(static_cast<std::size_t>(count), 0);
  for (int i = 0; i < n; ++i) {
    const std::size_t k = static_cast<std::size_t>(component_of_[static_cast<std::size_t>(i)]);
    const Entry& e = *nodes_[static_cast<std::size_t>(i)];
    component_objects_[static_cast<std::size_t>(cursor[k]++)] = e.body.get();
    if (e.role == Role::Ghost) ghost_in[k] = 1;
    if (e.role == Role::Owned && !e.sent_to.empty()) ghosted[k] = 1;
  }
  for (Held& h : held_) h.component = component_of_[static_cast<std::size_t>(h.component)];
  std::sort(held_.begin(), held_.end(), [](const Held& x, const Held& y) {
    if (x.component != y.component) return x.component < y.component;
    if (x.id0 != y.id0) return x.id0 < y.id0;
    return x.id1 < y.id1;
  });
  held_ptrs_.resize(held_.size());
  held_begin_.assign(static_cast<std::size_t>(count) + 1, 0);
  for (std::size_t i = 0; i < held_.size(); ++i) {
    held_ptrs_[i] = held_[i].manifold;
    ++held_begin_[static_cast<std::size_t>(held_[i].component) + 1];
  }
  for (int k = 0; k < count; ++k) held_begin_[static_cast<std::size_t>(k) + 1] += held_begin_[static_cast<std::size_t>(k)];

  // Classify: whole islands (no ghost, no body sent anywhere) are solved now.
  std::vector<int> local;
  components_.clear();
  pending_of_.assign(static_cast<std::size_t>(count), -1);
  glue_out_.clear();
  for (int k = 0; k < count; ++k) {
    const std::size_t uk = static_cast<std::size_t>(k);
    const int size = component_begin_[uk + 1] - component_begin_[uk];
    if (!ghost_in[uk] && !ghosted[uk]) {
      local.push_back(k);
      continue;
    }
    if (size == 1 && ghost_in[uk]) continue;  // a ghost touching nothing here
    pending_of_[uk] = static_cast<int>(components_.size());
    Component c;
    c.index = k;
    c.root = entry_of(component_objects_[static_cast<std::size_t>(component_begin_[uk])]).id();
    c.has_ghost = ghost_in[uk] != 0;
    components_.push_back(std::move(c));
    for (int j = component_begin_[uk]; j < component_begin_[uk + 1]; ++j) {
      const Entry& e = entry_of(component_objects_[static_cast<std::size_t>(j)]);
      if (e.role == Role::Ghost) glue_out_[e.owner].entries.push_back(GlueEntry{e.id(), c.root});
    }
  }
  solve_local(local);
}

GlueBatch TerritoryWorld::glue_batch_for(WorldId neighbour) const {
  auto it = glue_out_.find(neighbour);
  return it == glue_out_.end() ? GlueBatch{} : it->second;
}

std::vector<Fragment> TerritoryWorld::border_fragments(const std::vector<std::pair<WorldId, GlueBatch>>& glue) {
  for (const auto& [from, batch] : glue)
    for (const GlueEntry& g : batch.entries) {
      auto it = entries_.find(g.body);
      if (it == entries_.end() || it->second->role != Role::Owned)
        throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                             ": world " + std::to_string(from) + " glued body " + std::to_string(g.body) +
                             ", which this world does not own");
      const int k = component_of_[static_cast<std::size_t>(it->second->node)];
      const int p = pending_of_[static_cast<std::size_t>(k)];
      if (p < 0) throw std::logic_error("TerritoryWorld: a glued body in a component solved as local");
      components_[static_cast<std::size_t>(p)].links_in.push_back(LinkIn{from, g.fragment_root, g.body});
    }
  std::vector<int> local;
  std::vector<Fragment> fragments;
  held_by_key_.clear();
  own_fragments_.clear();
  solved_in_place_.clear();
  for (Component& c : components_) {
    const std::size_t uk = static_cast<std::size_t>(c.index);
    if (!c.has_ghost && c.links_in.empty()) {
      local.push_back(c.index);
      continue;
    }
    Fragment f;
    f.world = id_;
    f.root = c.root;
    for (int j = component_begin_[uk]; j < component_begin_[uk + 1]; ++j) {
      const Entry& e = entry_of(component_objects_[static_cast<std::size_t>(j)]);
      if (e.role == Role::Ghost) {
        f.links_out.push_back(LinkOut{e.owner, e.id()});
      } else {
        f.bodies.push_back(record_of(e));
      }
    }
    std::sort(f.links_out.begin(), f.links_out.end());
    if (!f.bodies.empty()) f.first_body = f.bodies.front().body.description.id;
    std::sort(c.links_in.begin(), c.links_in.end());
    f.links_in = c.links_in;
    f.manifolds.resize(static_cast<std::size_t>(held_begin_[uk + 1] - held_begin_[uk]));
    for (int j = held_begin_[uk]; j < held_begin_[uk + 1]; ++j) {
      btPersistentManifold* m = held_ptrs_[static_cast<std::size_t>(j)];
      ManifoldState& state = f.manifolds[static_cast<std::size_t>(j - held_begin_[uk])];
      read_manifold_state(*m, state);
      held_by_key_.emplace_back(PairKey{state.id0, state.id1}, m);
    }
    f.weight = static_cast<std::uint32_t>(f.bodies.size() + f.manifolds.size());
    own_fragments_.emplace_back(f.root, c.index);
    fragments.push_back(std::move(f));
  }
  std::sort(held_by_key_.begin(), held_by_key_.end());
  for (std::size_t i = 1; i < held_by_key_.size(); ++i)
    if (held_by_key_[i].first == held_by_key_[i - 1].first)
      throw std::logic_error("world " + std::to_string(id_) + ": two held manifolds of pair " +
                             std::to_string(held_by_key_[i].first.first) + "-" +
                             std::to_string(held_by_key_[i].first.second));
  counters_.border_fragments = fragments.size();
  solve_local(local);
  return fragments;
}

// As CanonicalDynamicsWorld's IslandStage, for whole islands of owned bodies
// (islands a replayed step can take from the old run are not solved).
void TerritoryWorld::solve_local(const std::vector<int>& components) {
  btConstraintSolver& solver = parts_->solver;
  btContactSolverInfo& info = parts_->world.getSolverInfo();
  std::vector<btCollisionObject*> lone;
  for (int k : components) {
    const std::size_t uk = static_cast<std::size_t>(k);
    btCollisionObject** bodies = &component_objects_[static_cast<std::size_t>(component_begin_[uk])];
    const int body_count = component_begin_[uk + 1] - component_begin_[uk];
    const int manifold_count = held_begin_[uk + 1] - held_begin_[uk];
    for (int j = 0; j < body_count; ++j) {
      bodies[j]->setCompanionId(-1);
      local_islands_.ids.push_back(entry_of(bodies[j]).id());
    }
    local_islands_.begin.push_back(static_cast<std::uint32_t>(local_islands_.ids.size()));
    if (replay_.islands && replay_island(bodies, body_count, uk)) {
      ++counters_.islands_replayed;
      counters_.bodies_replayed += static_cast<std::size_t>(body_count);
      if (!replay_.verify) continue;
    }
    if (!decide_island_sleeping(bodies, body_count)) continue;
    ++counters_.local_islands;
    if (body_count == 1 && manifold_count == 0) {
      lone.push_back(bodies[0]);
      continue;
    }
    btPersistentManifold** manifolds =
        manifold_count ? &held_ptrs_[static_cast<std::size_t>(held_begin_[uk])] : nullptr;
    int substeps = 1;
    const btContactSolverInfo& island_info =
        island_solver_info(info, parts_->island_info, bodies, body_count, manifolds, manifold_count, substeps);
    if (substeps > 1) ++counters_.substepped_islands;
    solve_island(solver, bodies, body_count, manifolds, manifold_count, island_info, substeps, parts_->dispatcher,
                 parts_->solver.pool().get());
  }
  // Lone bodies have no solver rows: one call for all is exact (as in the
  // canonical world).
  if (!lone.empty())
    solver.solveGroup(lone.data(), static_cast<int>(lone.size()), nullptr, 0, nullptr, 0, info, nullptr,
                      &parts_->dispatcher);
  if (replay_.mid_step) finish_replay();
}

// --- Rollback and Propagate: replayed islands -------------------------------

void TerritoryWorld::set_replay(const StepReplay& replay) {
  if (!replay.before || !replay.after || !replay.islands)
    throw std::invalid_argument("TerritoryWorld::set_replay: before, after and islands are required");
  replay_ = replay;
  const LocalIslands& old = *replay.islands;
  replay_index_.clear();
  for (std::uint32_t i = 0; i < old.size(); ++i) replay_index_.emplace_back(old.ids[old.begin[i]], i);
  std::sort(replay_index_.begin(), replay_index_.end());
}

// predict(), before anything moves: which owned bodies are clean. A pair
// whose contact state differs from the old run's, or that has contact
// state in one run only, makes both its bodies dirty.
void TerritoryWorld::mark_clean() {
  const WorldSnapshot& before = *replay_.before;
  auto b = before.bodies.begin();
  for (Entry* e : owned_) {
    while (b != before.bodies.end() && b->description.id < e->id()) ++b;
    e->clean = b != before.bodies.end() && b->description.id == e->id() &&
               same_bits(read_dynamic_state(*e->body), b->state);
  }
  auto dirty = [&](const ManifoldState& m) {
    for (BodyId id : {m.id0, m.id1})
      if (auto it = entries_.find(id); it != entries_.end()) it->second->clean = false;
  };
  const std::vector<ManifoldState> now = kept_contact_state();
  auto key = [](const ManifoldState& m) { return std::make_pair(m.id0, m.id1); };
  auto x = now.begin();
  auto y = before.manifolds.begin();
  while (x != now.end() || y != before.manifolds.end()) {
    if (y == before.manifolds.end() || (x != now.end() && key(*x) < key(*y))) {
      dirty(*x++);
    } else if (x == now.end() || key(*y) < key(*x)) {
      dirty(*y++);
    } else {
      if (!same_bits(*x, *y)) dirty(*x);
      ++x, ++y;
    }
  }
}

// True if the old run solved an island of exactly these bodies, all clean,
// and its result for every body and manifold of the island is in `after`;
// then they are queued for finish_replay.
bool TerritoryWorld::replay_island(btCollisionObject** bodies, int body_count, std::size_t component) {
  for (int j = 0; j < body_count; ++j)
    if (!entry_of(bodies[j]).clean) return false;
  const BodyId first = entry_of(bodies[0]).id();
  auto it = std::lower_bound(replay_index_.begin(), replay_index_.end(), std::make_pair(first, std::uint32_t{0}));
  if (it == replay_index_.end() || it->first != first) return false;
  const LocalIslands& old = *replay_.islands;
  const std::uint32_t begin = old.begin[it->second];
  if (old.begin[it->second + 1] - begin != static_cast<std::uint32_t>(body_count)) return false;
  for (int j = 0; j < body_count; ++j)
    if (old.ids[begin + static_cast<std::uint32_t>(j)] != entry_of(bodies[j]).id()) return false;

  const WorldSnapshot& after = *replay_.after;
  const std::size_t bodies_mark = replayed_bodies_.size(), manifolds_mark = replayed_manifolds_.size();
  auto give_up = [&] {
    replayed_bodies_.resize(bodies_mark);
    replayed_manifolds_.resize(manifolds_mark);
    return false;
  };
  for (int j = 0; j < body_count; ++j) {
    const BodyId id = entry_of(bodies[j]).id();
    auto b = std::lower_bound(after.bodies.begin(), after.bodies.end(), id,
                              [](const BodySnapshot& s, BodyId x) { return s.description.id < x; });
    if (b == after.bodies.end() || b->description.id != id) return give_up();  // it left the world
    replayed_bodies_.emplace_back(bodies[j], &b->state);
  }
  for (int j = held_begin_[component]; j < held_begin_[component + 1]; ++j) {
    const Held& h = held_[static_cast<std::size_t>(j)];
    auto m = std::lower_bound(after.manifolds.begin(), after.manifolds.end(), std::make_pair(h.id0, h.id1),
                              [](const ManifoldState& s, const std::pair<BodyId, BodyId>& x) {
                                return std::make_pair(s.id0, s.id1) < x;
                              });
    // Absent from `after`: the old run's step left it empty (a refresh
    // between substeps, island_substeps.h, or a speculative point cleared):
    // finish_replay empties it (null state).
    const bool absent = m == after.manifolds.end() || m->id0 != h.id0 || m->id1 != h.id1;
    replayed_manifolds_.emplace_back(h.manifold, absent ? nullptr : &*m);
  }
  return true;
}

// End of integrate() (after solve_local for a mid-step replay): replayed
// islands take the old run's result (verify: the result just computed must
// be it).
void TerritoryWorld::finish_replay() {
  auto mismatch = [&](const std::string& what) {
    throw std::logic_error("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                           ": a replayed island's " + what + " differs from the old run's");
  };
  for (const auto& [object, state] : replayed_bodies_) {
    btRigidBody& rb = *btRigidBody::upcast(object);
    if (!replay_.verify) {
      write_dynamic_state(rb, *state);
    } else if (!same_bits(read_dynamic_state(rb), *state)) {
      mismatch("body " + std::to_string(entry_of(object).id()));
    }
  }
  for (const auto& [manifold, state] : replayed_manifolds_) {
    if (!state) {
      if (!replay_.verify) {
        manifold->clearManifold();
      } else if (manifold->getNumContacts() != 0) {
        mismatch("manifold " + std::to_string(entry_of(manifold->getBody0()).id()) + "-" +
                 std::to_string(entry_of(manifold->getBody1()).id()) + " (empty in the old run)");
      }
    } else if (!replay_.verify) {
      write_manifold_points(*state, *manifold);
    } else if (!same_bits(read_manifold_state(*manifold), *state)) {
      mismatch("manifold " + std::to_string(state->id0) + "-" + std::to_string(state->id1));
    }
  }
  replayed_bodies_.clear();
  replayed_manifolds_.clear();
}

int TerritoryWorld::take_own_fragment(const Fragment& f) {
  if (f.world != id_) return -1;
  auto it = std::find_if(own_fragments_.begin(), own_fragments_.end(),
                         [&](const std::pair<BodyId, int>& o) { return o.first == f.root; });
  if (it == own_fragments_.end()) return -1;
  const int component = it->second;
  own_fragments_.erase(it);
  const std::size_t uk = static_cast<std::size_t>(component);
  // The fragment must be the one border_fragments() made of the component.
  const std::size_t held = static_cast<std::size_t>(held_begin_[uk + 1] - held_begin_[uk]);
  bool same = f.manifolds.size() == held;
  for (std::size_t i = 0; same && i < held; ++i) {
    const Held& h = held_[static_cast<std::size_t>(held_begin_[uk]) + i];
    same = h.id0 == f.manifolds[i].id0 && h.id1 == f.manifolds[i].id1;
  }
  if (!same)
    throw std::logic_error("world " + std::to_string(id_) + ": fragment " + std::to_string(f.root) +
                           " is not the one this world made of its component");
  return component;
}

IslandResult TerritoryWorld::solve_border_island(const std::vector<const Fragment*>& island) {
  // Sort keys are held beside the pointers: comparing through the pointers
  // missed the cache at every step of the sort (this runs on the root alone).
  // `original`: this world's own body or held manifold, solved in place.
  struct IslandBody {
    BodyId id;
    const BodyRecord* record;
    btRigidBody* original;
  };
  struct HeldManifold {
    std::pair<BodyId, BodyId> key;
    const ManifoldState* state;
    btPersistentManifold* original;
  };
  std::vector<IslandBody> by_id;
  std::vector<HeldManifold> manifolds;
  bool any_in_place = false, copied_own = false;
  for (const Fragment* f : island) {
    const int component = take_own_fragment(*f);
    // An own fragment's bodies are its component's owned bodies, in order.
    int next = component >= 0 ? component_begin_[static_cast<std::size_t>(component)] : 0;
    const int last = component >= 0 ? component_begin_[static_cast<std::size_t>(component) + 1] : 0;
    for (const BodyRecord& r : f->bodies) {
      btRigidBody* original = nullptr;
      if (component >= 0) {
        while (next < last && entry_of(component_objects_[static_cast<std::size_t>(next)]).role != Role::Owned) ++next;
        if (next == last || entry_of(component_objects_[static_cast<std::size_t>(next)]).id() != r.body.description.id)
          throw std::logic_error("world " + std::to_string(id_) + ": body " +
                                 std::to_string(r.body.description.id) + " of its own fragment is not its own");
        original = btRigidBody::upcast(component_objects_[static_cast<std::size_t>(next++)]);
      }
      by_id.push_back(IslandBody{r.body.description.id, &r, original});
    }
    for (std::size_t i = 0; i < f->manifolds.size(); ++i) {
      const ManifoldState& m = f->manifolds[i];
      btPersistentManifold* original =
          component >= 0 ? held_ptrs_[static_cast<std::size_t>(held_begin_[static_cast<std::size_t>(component)]) + i]
                         : nullptr;
      manifolds.push_back(HeldManifold{{m.id0, m.id1}, &m, original});
    }
    if (f->world == id_) (component >= 0 ? any_in_place : copied_own) = true;
  }
  std::sort(by_id.begin(), by_id.end(), [](const IslandBody& a, const IslandBody& b) { return a.id < b.id; });
  std::sort(manifolds.begin(), manifolds.end(),
            [](const HeldManifold& a, const HeldManifold& b) { return a.key < b.key; });
  std::vector<const BodyRecord*> records(by_id.size());
  std::vector<BodyId> ids(by_id.size());  // for the searches below
  for (std::size_t i = 0; i < by_id.size(); ++i) ids[i] = by_id[i].id, records[i] = by_id[i].record;
  auto fail = [&](const std::string& what) {
    throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                         ", border island of body " +
                         (records.empty() ? std::string("?") : std::to_string(records[0]->body.description.id)) +
                         ": " + what);
  };
  if (records.empty()) fail("no bodies");
  for (std::size_t i = 1; i < ids.size(); ++i)
    if (ids[i] == ids[i - 1]) fail("body " + std::to_string(ids[i]) + " has two owners");
  for (std::size_t i = 1; i < manifolds.size(); ++i)
    if (manifolds[i].key == manifolds[i - 1].key)
      fail("pair " + std::to_string(manifolds[i].key.first) + "-" + std::to_string(manifolds[i].key.second) +
           " has two holders");
  // The island's part here is solved in place: apply_island_result leaves it
  // (if a part of it was solved on copies, writing the rest again is harmless).
  if (any_in_place && !copied_own) solved_in_place_.push_back(ids.front());

  // The other worlds' bodies: copies, in the state their owners sent. Made
  // here (the map of copies is this thread's), filled on the solver pool:
  // each item writes only its own copy, so any split gives the same bits.
  // This world's own bodies are in that state already (the fragment read it).
  SolverPool* pool = parts_->solver.pool().get();
  std::vector<btCollisionObject*> bodies(records.size());
  std::size_t in_place = 0;
  for (std::size_t i = 0; i < records.size(); ++i) {
    if (by_id[i].original) {
      bodies[i] = by_id[i].original;
      ++in_place;
      continue;
    }
    const BodySnapshot& b = records[i]->body;
    std::unique_ptr<Copy>& c = copies_[b.description.id];
    if (!c) {
      c = std::make_unique<Copy>();
      c->shape = make_collision_shape(b.description.shape);
      c->body = make_body_from_state(b.description, *c->shape, b.state);
      c->body->setUserIndex(static_cast<int>(b.description.id));
    }
    bodies[i] = c->body.get();
  }
  run_in_chunks(pool, static_cast<int>(records.size()), kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      btRigidBody& rb = *btRigidBody::upcast(bodies[static_cast<std::size_t>(i)]);
      rb.setCompanionId(-1);
      if (by_id[static_cast<std::size_t>(i)].original) continue;
      const BodyRecord& r = *records[static_cast<std::size_t>(i)];
      write_dynamic_state(rb, r.body.state);
      rb.clearForces();
      rb.applyCentralForce(btVector3(r.total_force[0], r.total_force[1], r.total_force[2]));
      rb.applyTorque(btVector3(r.total_torque[0], r.total_torque[1], r.total_torque[2]));
    }
  });
  auto object_of = [&](BodyId id) -> btCollisionObject* {
    auto it = std::lower_bound(ids.begin(), ids.end(), id);
    if (it != ids.end() && *it == id) return bodies[static_cast<std::size_t>(it - ids.begin())];
    auto s = entries_.find(id);
    if (s == entries_.end() || s->second->role != Role::Static)
      fail("manifold refers to body " + std::to_string(id) + ", which is neither in the island nor static");
    return s->second->body.get();
  };

  IslandResult result;
  result.island = records.front()->body.description.id;
  result.manifolds.resize(manifolds.size());
  const int manifold_count = static_cast<int>(manifolds.size());
  if (decide_island_sleeping(bodies.data(), static_cast<int>(bodies.size()))) {
    // The other worlds' manifolds: copies, each reset to what
    // CappedDispatcher::getNewManifold makes (thresholds as it gives them),
    // then the points. A manifold held here is solved in place; one
    // with a ghost at an end points at the copy of that body meanwhile (the
    // ghost is this world's view of another world's body, not the island's).
    std::vector<std::unique_ptr<btPersistentManifold>>& copies = parts_->manifold_copies;
    std::vector<btPersistentManifold*> ptrs(manifolds.size());
    std::vector<std::pair<btCollisionObject*, btCollisionObject*>> ends(manifolds.size());
    std::size_t copy_count = 0;
    for (std::size_t i = 0; i < manifolds.size(); ++i) {  // here: object_of may throw
      ends[i] = {object_of(manifolds[i].key.first), object_of(manifolds[i].key.second)};
      if (manifolds[i].original) {
        ptrs[i] = manifolds[i].original;
        continue;
      }
      if (copy_count == copies.size())
        copies.push_back(std::make_unique<btPersistentManifold>(nullptr, nullptr, 0, btScalar(0), btScalar(0)));
      ptrs[i] = copies[copy_count++].get();
    }
    // Held manifolds pointed at copies get their own bodies back however the
    // solve ends.
    struct Redirected {
      btPersistentManifold* manifold;
      const btCollisionObject* body0;
      const btCollisionObject* body1;
    };
    std::vector<Redirected> redirected;
    for (std::size_t i = 0; i < manifolds.size(); ++i) {
      btPersistentManifold* m = manifolds[i].original;
      if (m && (m->getBody0() != ends[i].first || m->getBody1() != ends[i].second)) {
        redirected.push_back(Redirected{m, m->getBody0(), m->getBody1()});
        m->setBodies(ends[i].first, ends[i].second);
      }
    }
    struct Restore {
      std::vector<Redirected>& list;
      ~Restore() {
        for (const Redirected& r : list) r.manifold->setBodies(r.body0, r.body1);
      }
    } restore{redirected};
    run_in_chunks(pool, manifold_count, kParallelMinPairs, kPairsPerTask, [&](int begin, int end) {
      for (int i = begin; i < end; ++i) {
        if (manifolds[static_cast<std::size_t>(i)].original) continue;
        const auto [b0, b1] = ends[static_cast<std::size_t>(i)];
        const btScalar breaking = manifold_breaking_threshold(*b0, *b1);
        const btScalar processing = btMin(b0->getContactProcessingThreshold(), b1->getContactProcessingThreshold());
        btPersistentManifold& m = *ptrs[static_cast<std::size_t>(i)];
        m = btPersistentManifold(b0, b1, 0, breaking, processing);
        write_manifold_points(*manifolds[static_cast<std::size_t>(i)].state, m);
      }
    });
    btPersistentManifold** manifold_ptrs = ptrs.empty() ? nullptr : ptrs.data();
    const int body_count = static_cast<int>(bodies.size());
    int substeps = 1;
    const btContactSolverInfo& info = island_solver_info(parts_->world.getSolverInfo(), parts_->island_info,
                                                         bodies.data(), body_count, manifold_ptrs, manifold_count,
                                                         substeps);
    if (substeps > 1) ++counters_.substepped_islands;
    solve_island(parts_->solver, bodies.data(), body_count, manifold_ptrs, manifold_count, info, substeps,
                 parts_->dispatcher, pool);
    run_in_chunks(pool, manifold_count, kParallelMinPairs, kPairsPerTask, [&](int begin, int end) {
      for (int i = begin; i < end; ++i)
        read_manifold_state(*ptrs[static_cast<std::size_t>(i)], result.manifolds[static_cast<std::size_t>(i)]);
    });
  } else {
    run_in_chunks(pool, manifold_count, kParallelMinPairs, kPairsPerTask, [&](int begin, int end) {
      for (int i = begin; i < end; ++i)
        result.manifolds[static_cast<std::size_t>(i)] = *manifolds[static_cast<std::size_t>(i)].state;
    });
  }
  result.bodies.resize(bodies.size());
  run_in_chunks(pool, static_cast<int>(bodies.size()), kParallelMinBodies, kBodiesPerTask, [&](int begin, int end) {
    for (int i = begin; i < end; ++i) {
      const btRigidBody& c = *static_cast<const btRigidBody*>(bodies[static_cast<std::size_t>(i)]);
      BodyResult& r = result.bodies[static_cast<std::size_t>(i)];
      r.id = records[static_cast<std::size_t>(i)]->body.description.id;
      const btTransform& t = c.getWorldTransform();
      for (int k = 0; k < 3; ++k) {
        r.linear_velocity[k] = c.getLinearVelocity()[k];
        r.angular_velocity[k] = c.getAngularVelocity()[k];
        r.origin[k] = t.getOrigin()[k];
        for (int j = 0; j < 3; ++j) r.basis[k * 3 + j] = t.getBasis()[k][j];
      }
      r.activation_state = c.getActivationState();
      r.deactivation_time = c.getDeactivationTime();
    }
  });
  ++counters_.islands_solved;
  counters_.merged_island_bodies += records.size();
  counters_.merged_island_bodies_in_place += in_place;
  return result;
}

void TerritoryWorld::apply_island_result(const IslandResult& result) {
  // Solved in place here (solve_border_island): this world's bodies and held
  // manifolds are the result already.
  auto solved_here = std::find(solved_in_place_.begin(), solved_in_place_.end(), result.island);
  const bool in_place = solved_here != solved_in_place_.end();
  if (in_place) solved_in_place_.erase(solved_here);
  for (const BodyResult& r : result.bodies) {
    if (in_place) break;  // the bodies (every owned one of the island) are the result already
    auto it = entries_.find(r.id);
    if (it == entries_.end() || it->second->role != Role::Owned) continue;
    btRigidBody& rb = *it->second->body;
    rb.setLinearVelocity(btVector3(r.linear_velocity[0], r.linear_velocity[1], r.linear_velocity[2]));
    rb.setAngularVelocity(btVector3(r.angular_velocity[0], r.angular_velocity[1], r.angular_velocity[2]));
    btTransform t;
    t.getBasis().setValue(r.basis[0], r.basis[1], r.basis[2], r.basis[3], r.basis[4], r.basis[5], r.basis[6],
                          r.basis[7], r.basis[8]);
    t.setOrigin(btVector3(r.origin[0], r.origin[1], r.origin[2]));
    rb.setWorldTransform(t);
    rb.forceActivationState(r.activation_state);
    rb.setDeactivationTime(r.deactivation_time);
  }
  // Both sorted by key: each search starts where the last one ended.
  auto held = held_by_key_.begin();
  PairKey last{0, 0};
  for (const ManifoldState& m : result.manifolds) {
    const PairKey key{m.id0, m.id1};
    if (&m != &result.manifolds.front() && !(last < key))
      throw std::logic_error("world " + std::to_string(id_) + ": island result " + std::to_string(result.island) +
                             " has its manifolds out of order");
    last = key;
    held = std::lower_bound(held, held_by_key_.end(), key,
                            [](const std::pair<PairKey, void*>& h, const PairKey& k) { return h.first < k; });
    if (held != held_by_key_.end() && held->first == key) {
      if (!in_place) write_manifold_points(m, *static_cast<btPersistentManifold*>(held->second));
    } else if (owns(key_of(key.first, key.second)) && !is_speculative(m) && !m.points.empty()) {
      // A speculative point is no contact state: it ends with the solve;
      // nor is an emptied manifold (substeps, island_substeps.h).
      kept_next_[key] = m;
      ++counters_.manifolds_returned;
    }
  }
}

void TerritoryWorld::finish_islands() {
  kept_ = std::move(kept_next_);
  kept_next_.clear();
  held_by_key_.clear();
  own_fragments_.clear();
  solved_in_place_.clear();
}

}  // namespace soda
