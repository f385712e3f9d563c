// TerritoryWorld, build_islands and solve (docs/partitioned-step.md):
//  - the contact graph of this world: owned bodies and ghosts (id order)
//    joined by the manifolds with points it holds (IslandBuilder,
//    island_builder.h, as the canonical world builds its islands);
//  - a component without ghosts whose owned bodies were sent to nobody is a
//    whole island: solved at once, in place, as the canonical world solves it
//    (or replayed: island_replay.h);
//  - the others wait for the neighbours' glue; those nobody glued are whole
//    islands too; the rest are fragments of border islands, merged by the
//    runtime and solved by their root (BorderIslandSolver,
//    border_island_solver.h).
#include <algorithm>
#include <stdexcept>
#include <string>

#include "canonical_dynamics_world.h"
#include "island_solver_settings.h"
#include "island_substeps.h"
#include "soda/scene/kinematic_command.h"
#include "soda/worlds/value_codec.h"
#include "territory_world_parts.h"

namespace soda {

// Islands over the nodes (dynamic bodies here, id order) joined by the
// manifolds with points, numbered by their smallest id; the manifolds of
// each (by (id0, id1)) in parts_->held. Whole islands are solved now; the others
// wait for glue.
void TerritoryWorld::build_islands() {
  sort_lists();
  nodes_.resize(owned_.size() + ghosts_.size());
  std::merge(owned_.begin(), owned_.end(), ghosts_.begin(), ghosts_.end(), nodes_.begin(),
             [](const Entry* a, const Entry* b) { return a->id() < b->id(); });
  for (Entry* e : statics_) e->node = IslandBuilder::kNoNode;
  const int n = static_cast<int>(nodes_.size());
  for (int i = 0; i < n; ++i) nodes_[static_cast<std::size_t>(i)]->node = i;
  parts_->islands.reset(n);
  btDispatcher& d = parts_->dispatcher;
  const int manifolds = d.getNumManifolds();
  for (int i = 0; i < manifolds; ++i) {
    const btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;  // every manifold with points is held here (invariant 3)
    parts_->islands.join(entry_of(m->getBody0()).node, entry_of(m->getBody1()).node);
  }
  // Joints that hold: an edge like a manifold with points (their bodies are
  // owned here or static, invariant 6).
  for (const auto& [id, j] : joints_)
    if (j->constraint->isEnabled())
      parts_->islands.join(entry_of(&j->constraint->getRigidBodyA()).node,
                           entry_of(&j->constraint->getRigidBodyB()).node);
  parts_->islands.finish();
  const int count = parts_->islands.island_count();
  parts_->held.clear();
  for (int i = 0; i < manifolds; ++i) {
    btPersistentManifold* m = d.getManifoldByIndexInternal(i);
    if (m->getNumContacts() == 0) continue;
    const Entry& a = entry_of(m->getBody0());
    const Entry& b = entry_of(m->getBody1());
    parts_->held.add(parts_->islands.island_of(a.node >= 0 ? a.node : b.node), {a.id(), b.id()}, m);
  }
  parts_->held.finish(count);
  counters_.held_manifolds = parts_->held.size();
  parts_->joints.clear();
  for (const auto& [id, j] : joints_) {
    if (!j->constraint->isEnabled()) continue;
    const Entry& a = entry_of(&j->constraint->getRigidBodyA());
    const Entry& b = entry_of(&j->constraint->getRigidBodyB());
    parts_->joints.add(parts_->islands.island_of(a.node >= 0 ? a.node : b.node), id, j->constraint.get());
  }
  parts_->joints.finish(count);

  component_objects_.resize(static_cast<std::size_t>(n));
  std::vector<std::uint8_t> ghost_in(static_cast<std::size_t>(count), 0), ghosted(static_cast<std::size_t>(count), 0);
  for (int i = 0; i < n; ++i) {
    const Entry& e = *nodes_[static_cast<std::size_t>(parts_->islands.order()[static_cast<std::size_t>(i)])];
    component_objects_[static_cast<std::size_t>(i)] = e.body.get();
    const std::size_t k = static_cast<std::size_t>(parts_->islands.island_of(e.node));
    if (e.role == Role::Ghost) ghost_in[k] = 1;
    if (e.role == Role::Owned && !e.sent_to.empty()) ghosted[k] = 1;
  }

  // Classify: whole islands (no ghost, no body sent anywhere) are solved now.
  std::vector<int> local;
  components_.clear();
  pending_of_.assign(static_cast<std::size_t>(count), -1);
  glue_out_.clear();
  for (int k = 0; k < count; ++k) {
    const std::size_t uk = static_cast<std::size_t>(k);
    if (!ghost_in[uk] && !ghosted[uk]) {
      local.push_back(k);
      continue;
    }
    if (parts_->islands.size(k) == 1 && ghost_in[uk]) continue;  // a ghost touching nothing here
    pending_of_[uk] = static_cast<int>(components_.size());
    Component c;
    c.index = k;
    c.root = entry_of(component_objects_[static_cast<std::size_t>(parts_->islands.begin(k))]).id();
    c.has_ghost = ghost_in[uk] != 0;
    components_.push_back(std::move(c));
    for (int j = parts_->islands.begin(k); j < parts_->islands.begin(k + 1); ++j) {
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
      // Running ahead, a neighbour that rejoined its old run may glue from
      // ghosts of that run (a body since removed or moved here, a component
      // this run solves alone): left out, as apply_ghosts leaves its ghosts;
      // the neighbour's Notice rolls this step back.
      const bool owned = it != entries_.end() && it->second->role == Role::Owned;
      const int p = owned ? pending_of_[static_cast<std::size_t>(parts_->islands.island_of(it->second->node))] : -1;
      if (p < 0 && parts_->step_runs_ahead) continue;
      if (!owned)
        throw PartitionError("world " + std::to_string(id_) + ", step " + std::to_string(steps_done_) +
                             ": world " + std::to_string(from) + " glued body " + std::to_string(g.body) +
                             ", which this world does not own");
      if (p < 0) throw std::logic_error("TerritoryWorld: a glued body in a component solved as local");
      components_[static_cast<std::size_t>(p)].links_in.push_back(LinkIn{from, g.fragment_root, g.body});
    }
  std::vector<int> local;
  std::vector<Fragment> fragments;
  BorderIslandSolver& border = parts_->border;
  border.begin_fragments();
  for (Component& c : components_) {
    const int k = c.index;
    if (!c.has_ghost && c.links_in.empty()) {
      local.push_back(k);
      continue;
    }
    Fragment f;
    f.world = id_;
    f.root = c.root;
    for (int j = parts_->islands.begin(k); j < parts_->islands.begin(k + 1); ++j) {
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
    f.manifolds.resize(static_cast<std::size_t>(parts_->held.count(k)));
    for (int j = parts_->held.begin(k); j < parts_->held.begin(k + 1); ++j) {
      ManifoldState& state = f.manifolds[static_cast<std::size_t>(j - parts_->held.begin(k))];
      btPersistentManifold* m = parts_->held[static_cast<std::size_t>(j)].value;
      read_manifold_state(*m, state);
      border.hold({state.id0, state.id1}, m);
    }
    for (int j = parts_->joints.begin(k); j < parts_->joints.begin(k + 1); ++j)
      f.joints.push_back(joints_.at(parts_->joints[static_cast<std::size_t>(j)].key)->description);
    f.weight = static_cast<std::uint32_t>(f.bodies.size() + f.manifolds.size());
    border.note_own_fragment(f.root, k);
    fragments.push_back(std::move(f));
  }
  border.end_fragments();
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
    btCollisionObject** bodies = &component_objects_[static_cast<std::size_t>(parts_->islands.begin(k))];
    const int body_count = parts_->islands.size(k);
    const int manifold_count = parts_->held.count(k);
    const int joint_count = parts_->joints.count(k);
    for (int j = 0; j < body_count; ++j) {
      bodies[j]->setCompanionId(-1);
      local_islands_.ids.push_back(entry_of(bodies[j]).id());
    }
    local_islands_.begin.push_back(static_cast<std::uint32_t>(local_islands_.ids.size()));
    // An island with joints is always solved: whether a joint holds is
    // part of its contents, which the replay does not compare. One touching
    // a commanded kinematic body too: the old run may have had other commands.
    if (joint_count == 0 && parts_->replay.armed() && !touches_commanded_kinematic(k) &&
        parts_->replay.take(bodies, body_count, parts_->held, k)) {
      ++counters_.islands_replayed;
      counters_.bodies_replayed += static_cast<std::size_t>(body_count);
      if (!parts_->replay.verify()) continue;
    }
    if (!wake_touched_by_kinematic(decide_island_sleeping(bodies, body_count), bodies, body_count,
                                   parts_->held.values(k), manifold_count))
      continue;
    ++counters_.local_islands;
    if (body_count == 1 && manifold_count == 0 && joint_count == 0) {
      lone.push_back(bodies[0]);
      continue;
    }
    btPersistentManifold** manifolds = parts_->held.values(k);
    int substeps = 1;
    const btContactSolverInfo& island_info = island_solver_info(
        info, parts_->island_info, bodies, body_count, manifolds, manifold_count, parts_->joints.values(k),
        joint_count, substeps);
    if (substeps > 1) ++counters_.substepped_islands;
    solve_island(solver, bodies, body_count, manifolds, manifold_count, island_info, substeps, parts_->dispatcher,
                 parts_->solver.pool().get(), parts_->joints.values(k), joint_count);
  }
  // Lone bodies have no solver rows: one call for all is exact (as in the
  // canonical world).
  if (!lone.empty())
    solver.solveGroup(lone.data(), static_cast<int>(lone.size()), nullptr, 0, nullptr, 0, info, nullptr,
                      &parts_->dispatcher);
  if (parts_->replay.armed() && parts_->replay.mid_step()) parts_->replay.finish(id_, steps_done_);
}

// --- Rollback and Propagate: replayed islands (island_replay.h) -------------

void TerritoryWorld::set_replay(const StepReplay& replay) { parts_->replay.set(replay); }

bool TerritoryWorld::touches_commanded_kinematic(int island) const {
  const std::vector<btPersistentManifold*>& ms = parts_->held.values();
  for (int i = parts_->held.begin(island); i < parts_->held.begin(island + 1); ++i)
    for (const btCollisionObject* o : {ms[static_cast<std::size_t>(i)]->getBody0(), ms[static_cast<std::size_t>(i)]->getBody1()}) {
      const Entry& e = entry_of(o);
      if (e.description.kinematic && commanded(e.description)) return true;
    }
  return false;
}

// predict(), before anything moves: which owned bodies are clean.
void TerritoryWorld::mark_clean() {
  std::vector<btRigidBody*> owned(owned_.size());
  std::vector<const Body*> descriptions(owned_.size());
  for (std::size_t i = 0; i < owned_.size(); ++i) {
    owned[i] = owned_[i]->body.get();
    descriptions[i] = &owned_[i]->description;
  }
  std::vector<JointSnapshot> joints;  // by id, as a snapshot has them
  joints.reserve(joints_.size());
  for (const auto& [id, j] : joints_) joints.push_back(JointSnapshot{j->description, !j->constraint->isEnabled()});
  parts_->replay.mark_clean(owned, descriptions, kept_contact_state(), joints, settings_.gravity);
}

// --- border islands (border_island_solver.h) ---------------------------------

IslandResult TerritoryWorld::solve_border_island(const std::vector<const Fragment*>& island) {
  const BorderIslandTools tools{parts_->solver, parts_->dispatcher, parts_->world.getSolverInfo(),
                                parts_->island_info, parts_->solver.pool().get()};
  return parts_->border.solve(island, tools, steps_done_, counters_);
}

void TerritoryWorld::apply_island_result(const IslandResult& result) {
  parts_->border.apply(result, kept_next_, counters_);
}

void TerritoryWorld::finish_islands() {
  kept_ = std::move(kept_next_);
  kept_next_.clear();
  parts_->border.end_step();
}

// What the border-island solver reads of this world.
btCollisionObject* const* TerritoryWorld::BorderLink::component_bodies(int component, int& count) const {
  count = world->parts_->islands.size(component);
  return world->component_objects_.data() + world->parts_->islands.begin(component);
}

btPersistentManifold* const* TerritoryWorld::BorderLink::component_manifolds(int component, int& count) const {
  count = world->parts_->held.count(component);
  return world->parts_->held.values(component);
}

bool TerritoryWorld::BorderLink::owns_body(const btCollisionObject* body) const {
  return entry_of(body).role == Role::Owned;
}

btCollisionObject* TerritoryWorld::BorderLink::static_body(BodyId id) const {
  return world->parts_->statics.object(id);  // a fixed static not held here: a detached copy
}

btRigidBody* TerritoryWorld::BorderLink::owned_body(BodyId id) const {
  auto it = world->entries_.find(id);
  return it == world->entries_.end() || it->second->role != Role::Owned ? nullptr : it->second->body.get();
}

bool TerritoryWorld::BorderLink::keeps_pair(BodyId id0, BodyId id1) const {
  return world->owns(world->key_of(id0, id1));
}

}  // namespace soda
