#include "world_process.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>

#include "run_control.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/scene_reader.h"

namespace soda {

PartitionedWorld::Process::Process(TerritoryWorld& world, Transport& transport, const WorldGraph& graph,
                                   Validator* validator, std::function<void(std::int64_t)> progress, int substeps,
                                   bool solve_everywhere, Safety safety)
    : world_(&world),
      transport_(transport),
      graph_(graph),
      validator_(validator),
      progress_(std::move(progress)),
      substeps_(substeps),
      solve_everywhere_(solve_everywhere),
      neighbours_(graph.neighbours(world.id())),
      safety_(safety),
      step_(world.steps_done()) {
  // Speculation keeps a state every checkpoint_every internal steps (a
  // rollback restores the one at or before the step and re-runs the rest).
  checkpoint_every_ = speculating() && !safety_.keep_states ? safety_.checkpoint_every : 1;
  sums_.world = world.id();
  sums_.neighbours = neighbours_.size();
  if (safety_.keep_states || speculating()) kept_states_.emplace(step_, world_->part_snapshot());
}

void PartitionedWorld::Process::rewind(TerritoryWorld& world, std::int64_t scene_step) {
  world_ = &world;
  step_ = scene_step * substeps_;
  phase_ = Phase::Predict;
  inbox_.clear();
  fragments_.clear();
  merger_ = IslandMerger{};
  islands_.clear();
  early_gathers_.clear();
  pending_.reset();
  backlog_.clear();
  publish_current_ = false;
  room_wait_since_ns_ = 0;
  next_publish_ = scene_step + 1;  // the buffer dropped the later entries
  kept_states_.erase(kept_states_.upper_bound(step_), kept_states_.end());
  used_.clear();
  sent_log_.clear();
  island_log_.clear();
  old_run_.reset();
  partial_step_.reset();
  unconfirmed_.clear();
  bets_in_inbox_.clear();
  merge_steps_.clear();
  reports_.erase(reports_.upper_bound(step_), reports_.end());
  if (safety_.horizon) safety_.horizon->report(world_->id(), step_);
}

// Inputs at this boundary, in sequence order; each world applies those that
// concern its territory (the owner of a body, the owner of a new body's home
// cell), so that exactly one world applies each.
void PartitionedWorld::Process::apply_inputs() {
  for (const UserInput& in : output_.inputs->at(step_ / substeps_)) {
    switch (in.kind) {
      case UserInput::Kind::AddBody: world_->add_body(in.body); break;
      case UserInput::Kind::RemoveBody: world_->remove_body(in.id); break;
      case UserInput::Kind::SetVelocity: world_->set_velocity(in.id, in.linear, in.angular); break;
      case UserInput::Kind::ApplyImpulse: world_->apply_impulse(in.id, in.linear); break;
    }
  }
}

const WorldSnapshot* PartitionedWorld::Process::kept_state(std::int64_t scene_step) const {
  auto it = kept_states_.find(scene_step * substeps_);
  return it == kept_states_.end() ? nullptr : &it->second;
}

// After integrate, before anything of the step leaves the world: a bad state
// never reaches a neighbour.
void PartitionedWorld::Process::check_watchdog() {
  const std::int64_t scene_step = step_ / substeps_ + 1;
  if (safety_.fault.step == scene_step && safety_.fault_fired && !safety_.fault_fired->load() &&
      world_->set_velocity(safety_.fault.body, Vec3::Constant(std::nan("")), Vec3::Zero()))
    safety_.fault_fired->store(true);
  if (!safety_.watchdog || safety_.watchdog->response == WatchdogResponse::Off) return;
  std::vector<WatchdogFinding> findings = world_->watchdog_findings(safety_.watchdog->limits);
  if (!findings.empty()) throw WatchdogError(scene_step, world_->id(), std::move(findings), safety_.watchdog->limits);
}

void PartitionedWorld::Process::deliver(Message m) {
  if (m.to != world_->id())
    throw std::logic_error("world " + std::to_string(world_->id()) + " got " + describe(m));
  const Control* control = std::get_if<Control>(&m.payload);
  if (control && control->type == Control::Type::Wake && m.from == m.to) return;  // it has woken us
  if (!graph_.adjacent(world_->id(), m.from))
    throw PartitionError("world " + std::to_string(world_->id()) + " got " + describe(m) +
                         " from a world that is not a neighbour");
  if (speculating()) {
    if (m.epoch > seen_epoch_) catch_up();  // a rollback of every world its sender saw first
    if (control) {
      // The sender's pin holds the horizon at the notice's step until this
      // world's mark covers the uses the notice voids (take_notice reports
      // it): released first, the horizon could pass the step meanwhile and
      // a world trim the states a rollback to it needs.
      if (!safety_.board->voids(m.epoch, control->rolled_to, seen_epoch_)) take_notice(m.from, control->rolled_to);
      safety_.horizon->unpin(control->pinned);  // pinned by its sender
      return;
    }
    if (safety_.board->voids(m.epoch, m.step, seen_epoch_)) return;
    if (m.kind() == MessageKind::Ghosts) {
      auto [it, fresh] = newest_ghosts_.try_emplace(m.from, m.step, false);
      if (fresh || m.step >= it->second.first)
        it->second = {m.step, !std::get<GhostBatch>(m.payload).ghosts.empty()};
    }
    if (!is_merge_message(m) && compare_with_used(m)) return;
    // Glue of a step whose glue this world no longer waits for: not needed
    // (a neighbour re-sent it after rolling back).
    if (m.kind() == MessageKind::Glue &&
        (m.step < step_ || (m.step == step_ && phase_ != Phase::Predict && phase_ != Phase::AwaitGhosts &&
                            phase_ != Phase::AwaitGlue)))
      return;
  }
  if (m.kind() == MessageKind::Fragments || m.kind() == MessageKind::Results || m.kind() == MessageKind::Gather) {
    // Late fragments of a step whose merge is over are dropped: the island
    // they belong to is complete here (island_merge.h).
    const bool late = m.step < step_ || (m.step == step_ && phase_ == Phase::AwaitMigrants);
    if (!late) fragments_[m.step].push_back(std::move(m));
    return;
  }
  if (m.step < step_) throw std::logic_error("world " + std::to_string(world_->id()) + " got a stale " + describe(m));
  const Key key{static_cast<int>(m.kind()), m.step, m.from};
  if (inbox_.count(key)) throw std::logic_error("world " + std::to_string(world_->id()) + " got " + describe(m) + " twice");
  inbox_.emplace(key, std::move(m));
}

PartitionedWorld::Process::Advance PartitionedWorld::Process::advance() {
  // A pending rollback first: the mailbox may already hold messages of the
  // re-run steps from neighbours that rewound before this world.
  if (speculating()) catch_up();
  if (phase_ == Phase::Predict && output_.rewind && output_.control)
    if (std::shared_ptr<const WorldSnapshot> state = output_.control->take_rewind(world_->id()))
      output_.rewind(*state);
  Advance result;
  while (std::optional<Message> m = transport_.try_receive(world_->id())) {
    deliver(std::move(*m));
    result.progressed = result.progressed || speculating();  // it may have confirmed a bet
  }
  std::int64_t cpu0 = thread_cpu_ns();
  for (;;) {
    if (phase_ == Phase::Predict && !may_start()) {
      // Speculating, the world is done only once no step of it can change:
      // once the commit horizon reaches its clock.
      result.done = !speculating() || !safety_.horizon->wake_at(world_->id(), step_);
      break;
    }
    const std::int64_t before = step_;
    if (!run_phase()) break;
    result.progressed = true;
    if (step_ != before) {  // a step ended: its CPU time is complete
      const std::int64_t now = thread_cpu_ns();
      step_cpu_ns_ += now - cpu0;
      cpu_ns_ += step_cpu_ns_;
      step_cpu_max_ns_ = std::max(step_cpu_max_ns_, step_cpu_ns_);
      step_cpu_history_ns_.push_back(step_cpu_ns_);
      if (step_ <= rerun_until_) rollback_cpu_ns_ += step_cpu_ns_ - restore_ns_in_step_;  // restores: counted
      step_cpu_ns_ = 0;
      restore_ns_in_step_ = 0;
      cpu0 = now;
    }
  }
  step_cpu_ns_ += thread_cpu_ns() - cpu0;
  report_committed();
  return result;
}

bool PartitionedWorld::Process::have_all(MessageKind kind, const std::vector<WorldId>& from) const {
  for (WorldId n : from)
    if (!inbox_.count(Key{static_cast<int>(kind), step_, n})) return false;
  return true;
}

template <class Batch>
std::vector<std::pair<WorldId, Batch>> PartitionedWorld::Process::take_all(MessageKind kind,
                                                                           const std::vector<WorldId>& from) {
  std::vector<std::pair<WorldId, Batch>> out;
  for (WorldId n : from) {
    auto it = inbox_.find(Key{static_cast<int>(kind), step_, n});
    if (speculating()) record_used(it->first, it->second);
    out.emplace_back(n, std::get<Batch>(std::move(it->second.payload)));
    inbox_.erase(it);
  }
  return out;
}

void PartitionedWorld::Process::send(WorldId to, Message message) {
  message.from = world_->id();
  message.to = to;
  message.step = step_;
  message.epoch = seen_epoch_;
  if (speculating()) {
    if (is_merge_message(message)) {
      merge_steps_.insert(step_);
    } else if (message.kind() != MessageKind::Control) {
      sent_log_[step_].push_back(message);  // re-sent if a re-run rejoins the run that sent it
    }
  }
  ++sums_.messages_sent;
  transport_.send(to, std::move(message));
}

bool PartitionedWorld::Process::run_phase() {
  if (safety_.fuzz) fuzz_pause(*safety_.fuzz);
  switch (phase_) {
    case Phase::Predict: {
      if (output_.inputs && step_ % substeps_ == 0) apply_inputs();
      if (old_run_ || partial_step_) arm_replay();
      world_->predict();
      for (WorldId n : neighbours_) send(n, Message{.payload = world_->ghost_batch_for(n)});
      phase_ = Phase::AwaitGhosts;
      return true;
    }
    case Phase::AwaitGhosts: {
      if (!have_all(MessageKind::Ghosts, neighbours_) && !(speculating() && place_bets(MessageKind::Ghosts)))
        return false;
      world_->apply_ghosts(take_all<GhostBatch>(MessageKind::Ghosts, neighbours_));
      world_->collide();
      world_->build_islands();
      for (WorldId n : neighbours_)
        if (world_->received_ghosts_from(n)) send(n, Message{.payload = world_->glue_batch_for(n)});
      phase_ = Phase::AwaitGlue;
      return true;
    }
    case Phase::AwaitGlue: {
      std::vector<WorldId> from;
      for (WorldId n : neighbours_)
        if (world_->sends_ghosts_to(n)) from.push_back(n);
      if (!have_all(MessageKind::Glue, from)) return false;
      merger_.start(world_->id(), world_->border_fragments(take_all<GlueBatch>(MessageKind::Glue, from)),
                    solve_everywhere_);
      flush_merger();
      phase_ = Phase::Merging;
      return true;
    }
    case Phase::Merging: {
      bool progressed = false;
      auto it = fragments_.find(step_);
      if (it != fragments_.end()) {
        std::vector<Message> batch = std::move(it->second);
        fragments_.erase(it);
        for (Message& m : batch) {
          ++sums_.relay_messages_received;
          if (speculating()) merge_steps_.insert(step_);
          if (m.kind() == MessageKind::Results) {
            for (IslandResult& r : std::get<ResultBatch>(m.payload).results) take_result(std::move(r));
          } else if (m.kind() == MessageKind::Gather) {
            GatherBatch& g = std::get<GatherBatch>(m.payload);
            take_gather(g.island, std::move(g.fragments));
          } else if (!merger_.done()) {
            merger_.receive(m.from, std::get<FragmentBatch>(std::move(m.payload)).fragments);
          }
          flush_merger();
        }
        progressed = true;
      }
      if (!merger_.done() || !islands_.empty()) return progressed;
      if (!early_gathers_.empty())
        throw std::logic_error("world " + std::to_string(world_->id()) + ": data for an island it is not in");
      sums_.fragments_relayed += merger_.fragments_relayed();
      world_->finish_islands();
      world_->integrate();
      check_watchdog();
      for (auto& [n, batch] : world_->migrate()) send(n, Message{.payload = std::move(batch)});
      phase_ = Phase::AwaitMigrants;
      return true;
    }
    case Phase::AwaitMigrants: {
      if (!have_all(MessageKind::Migrants, neighbours_) && !(speculating() && place_bets(MessageKind::Migrants)))
        return false;
      world_->absorb_migrants(take_all<MigrantBatch>(MessageKind::Migrants, neighbours_));
      end_step();
      return true;
    }
    case Phase::Publish: return try_publish();
  }
  return false;
}

bool PartitionedWorld::Process::may_start() {
  return output_.control ? output_.control->may_start(world_->id(), step_) : step_ < target_;
}

// Publish: first the entries a rejoin took back (backlog_), then, if due,
// the entry of the step just ended, made once; a full buffer keeps it
// pending. A stopped buffer drops it (the run is being stopped).
bool PartitionedWorld::Process::try_publish() {
  while (!backlog_.empty()) {
    const std::int64_t scene_step = backlog_.front().step;
    if (output_.buffer->try_publish(std::move(backlog_.front()))) {
      backlog_.pop_front();
      entry_published(scene_step, true);
    } else if (!output_.buffer->stopped()) {
      if (!room_wait_since_ns_) room_wait_since_ns_ = wall_ns();
      return false;
    } else {
      backlog_.pop_front();
      entry_published(scene_step, false);
    }
  }
  if (!publish_current_) {
    phase_ = Phase::Predict;
    return true;
  }
  if (!pending_) pending_ = entry_of(step_ / substeps_, world_->owned_states());
  if (output_.buffer->try_publish(std::move(*pending_))) {
    published(true);
    return true;
  }
  if (!output_.buffer->stopped()) {
    if (!room_wait_since_ns_) room_wait_since_ns_ = wall_ns();
    return false;
  }
  published(false);
  return true;
}

// The entry of scene step `scene_step`: the poses of the owned bodies' states.
TransformEntry<btScalar> PartitionedWorld::Process::entry_of(std::int64_t scene_step,
                                                            const std::vector<BodyState>& states) const {
  TransformEntry<btScalar> e;
  e.step = scene_step;
  e.time = scene_time(scene_step, output_.dt);
  e.poses.reserve(states.size());
  for (const BodyState& b : states) e.poses.push_back(body_pose(b));
  return e;
}

void PartitionedWorld::Process::publish_blocking() {
  while (!backlog_.empty()) {
    if (!room_wait_since_ns_) room_wait_since_ns_ = wall_ns();
    const std::int64_t scene_step = backlog_.front().step;
    const bool kept = output_.buffer->publish(std::move(backlog_.front()));
    backlog_.pop_front();
    entry_published(scene_step, kept);
  }
  if (!pending_) {
    if (try_publish()) return;
  }
  if (!room_wait_since_ns_) room_wait_since_ns_ = wall_ns();
  published(output_.buffer->publish(std::move(*pending_)));
}

// Without speculation no step is ever rolled back: the commit step follows
// the writer, one behind, so that the newest entry stays readable even with
// no reader (a reader added later starts from it).
void PartitionedWorld::Process::published(bool kept) {
  const std::int64_t scene_step = pending_->step;
  pending_.reset();
  publish_current_ = false;
  phase_ = Phase::Predict;
  entry_published(scene_step, kept);
}

void PartitionedWorld::Process::entry_published(std::int64_t scene_step, bool kept) {
  if (room_wait_since_ns_) room_blocked_ns_ += wall_ns() - room_wait_since_ns_;
  room_wait_since_ns_ = 0;
  next_publish_ = scene_step + 1;
  if (!kept) {
    ++entries_dropped_;
    return;
  }
  ++entries_published_;
  if (speculating()) {
    last_published_ = scene_step;
    report_committed();
    return;
  }
  // Kept states (rollback for past inputs): a step above GVT may still be
  // rewritten, so only steps below it are committed.
  std::int64_t commit = scene_step - 1;
  if (safety_.keep_states) commit = std::min(commit, safety_.horizon->gvt() / substeps_ - 1);
  if (commit > output_.buffer->commit_step()) output_.buffer->set_commit_step(commit);
  output_.control->published(world_->id(), scene_step);
}

// Speculation under a Simulation: entries above the commit horizon may still
// be rewritten. The buffer's commit step follows GVT (one behind the newest
// entry, which stays readable), and the RunControl hears only of committed
// steps, so advance_to() and the readouts never see a speculative state.
void PartitionedWorld::Process::report_committed() {
  if (!output_.control || !speculating()) return;
  const std::int64_t horizon = safety_.horizon->gvt() / substeps_;
  const std::int64_t commit = std::min(last_published_ - 1, horizon - 1);
  if (commit > output_.buffer->commit_step()) output_.buffer->set_commit_step(commit);
  const std::int64_t committed = std::min(last_published_, horizon);
  if (committed > committed_reported_) {
    committed_reported_ = committed;
    output_.control->published(world_->id(), committed);
  }
}

void PartitionedWorld::Process::flush_merger() {
  for (auto& [n, fragments] : merger_.take_outgoing()) {
    ++sums_.relay_messages_sent;
    send(n, Message{.payload = FragmentBatch{std::move(fragments)}});
  }
  for (const std::vector<const Fragment*>& island : merger_.take_closed()) close_island(island);
}

// An island is complete here. Its root is the owner of its smallest body;
// its tree is the BFS tree of its worlds (joined by its links, ascending)
// from the root, the same in every world.
void PartitionedWorld::Process::close_island(const std::vector<const Fragment*>& island) {
  std::map<WorldId, std::set<WorldId>> adjacent;
  BodyId smallest = kNoBody;
  WorldId root = kNoWorld;
  for (const Fragment* f : island) {
    adjacent[f->world];
    for (const LinkOut& l : f->links_out) adjacent[f->world].insert(l.owner), adjacent[l.owner].insert(f->world);
    for (const LinkIn& l : f->links_in) adjacent[f->world].insert(l.world), adjacent[l.world].insert(f->world);
    if (f->first_body < smallest) {
      smallest = f->first_body;
      root = f->world;
    }
  }
  ++sums_.merged_islands;
  sums_.merged_island_worlds_sum += adjacent.size();
  sums_.merged_island_worlds_max = std::max<std::uint64_t>(sums_.merged_island_worlds_max, adjacent.size());
  if (solve_everywhere_) {
    world_->apply_island_result(world_->solve_border_island(island));
    return;
  }
  std::map<WorldId, WorldId> parent{{root, root}};
  std::vector<WorldId> queue{root};
  for (std::size_t i = 0; i < queue.size(); ++i)
    for (WorldId n : adjacent[queue[i]])
      if (parent.emplace(n, queue[i]).second) queue.push_back(n);
  Island& is = islands_[smallest];
  is.root = root;
  is.parent = parent.at(world_->id());
  for (const auto& [w, p] : parent)
    if (p == world_->id() && w != world_->id()) is.children.push_back(w);
  for (const Fragment* f : island)
    if (f->world == world_->id()) is.data.push_back(*f);
  is.gathers_missing = is.children.size();
  auto early = early_gathers_.find(smallest);
  if (early != early_gathers_.end()) {
    std::vector<Fragment> fragments = std::move(early->second);
    early_gathers_.erase(early);
    take_gather(smallest, std::move(fragments));  // may complete the gather
    return;
  }
  if (is.gathers_missing == 0) gathered(smallest);
}

// A child's subtree data; data arriving before the island is complete here
// waits. A child's Gather always holds the child's own fragments, so the
// children heard from are the children with a fragment in the data.
void PartitionedWorld::Process::take_gather(BodyId island, std::vector<Fragment> fragments) {
  auto it = islands_.find(island);
  if (it == islands_.end()) {
    std::vector<Fragment>& e = early_gathers_[island];
    e.insert(e.end(), std::make_move_iterator(fragments.begin()), std::make_move_iterator(fragments.end()));
    return;
  }
  Island& is = it->second;
  for (Fragment& f : fragments) is.data.push_back(std::move(f));
  std::set<WorldId> worlds;
  for (const Fragment& f : is.data) worlds.insert(f.world);
  std::size_t heard = 0;
  for (WorldId c : is.children) heard += worlds.count(c);
  is.gathers_missing = is.children.size() - heard;
  if (is.gathers_missing == 0) gathered(island);
}

// The subtree's data is here: the root solves, the others pass it up.
void PartitionedWorld::Process::gathered(BodyId island) {
  Island& is = islands_.at(island);
  if (is.root != world_->id()) {
    ++sums_.relay_messages_sent;
    send(is.parent, Message{.payload = GatherBatch{island, std::move(is.data)}});
    is.data.clear();
    return;
  }
  std::sort(is.data.begin(), is.data.end(), [](const Fragment& a, const Fragment& b) {
    return std::make_pair(a.world, a.root) < std::make_pair(b.world, b.root);
  });
  std::vector<const Fragment*> fragments;
  for (const Fragment& f : is.data) fragments.push_back(&f);
  take_result(world_->solve_border_island(fragments));
}

// A solved island: keep this world's part and pass it down the tree. (It
// cannot arrive before the island is complete here: the root needs this
// world's data first.)
void PartitionedWorld::Process::take_result(IslandResult result) {
  auto it = islands_.find(result.island);
  if (it == islands_.end())
    throw std::logic_error("world " + std::to_string(world_->id()) + ": result for island " +
                           std::to_string(result.island) + ", which is not complete here");
  world_->apply_island_result(result);
  for (WorldId child : it->second.children) {
    ++sums_.relay_messages_sent;
    send(child, Message{.payload = ResultBatch{{result}}});
  }
  islands_.erase(it);
}

void PartitionedWorld::Process::end_step() {
  const TerritoryCounters& c = world_->counters();
  sums_.border_bodies += c.border_bodies;
  sums_.ghosts_sent += c.ghosts_sent;
  sums_.ghosts_received += c.ghosts_received;
  sums_.manifolds_attached += c.manifolds_attached;
  sums_.manifolds_seeded += c.manifolds_seeded;
  sums_.manifolds_returned += c.manifolds_returned;
  sums_.migrations_out += c.migrations_out;
  sums_.migrations_in += c.migrations_in;
  sums_.local_islands += c.local_islands;
  sums_.border_fragments += c.border_fragments;
  sums_.merged_island_bodies += c.border_island_bodies;
  sums_.islands_solved += c.border_islands;
  ++step_;
  phase_ = Phase::Predict;
  if (validator_) {
    WorldStepReport report{world_->id(), step_, world_->owned_ids(), world_->ghost_count(),
                           world_->static_count(), world_->bullet_object_count(), world_->held_contact_pairs()};
    if (speculating()) {
      if (step_ > reported_through_) reports_.insert_or_assign(step_, std::move(report));  // once committed
    } else {
      validator_->report(std::move(report));
    }
  }
  if (speculating()) {
    if (partial_step_ && partial_step_->step < step_) partial_step_.reset();
    if (step_ <= rerun_until_) {
      bodies_resolved_ += world_->owned_count() - std::min(world_->owned_count(), c.bodies_replayed);
      bodies_replayed_ += c.bodies_replayed;
    }
    if (!safety_.recompute) {
      // Replaying a re-run (arm_replay) needs the islands of every step a
      // rollback may restore.
      island_log_[step_ - 1] = world_->local_islands();
    }
    if (step_ % checkpoint_every_ == 0) {
      WorldSnapshot snapshot;
      if (!spare_states_.empty()) {
        snapshot = std::move(spare_states_.back());
        spare_states_.pop_back();
      }
      world_->part_snapshot(snapshot);
      kept_states_.insert_or_assign(step_, std::move(snapshot));
    }
    kept_max_ = std::max(kept_max_, kept_states_.size());
    report_mark();
    const std::int64_t gvt = safety_.horizon->gvt();
    lead_.push_back(static_cast<std::int32_t>(step_ - gvt));
    trim_below(gvt);
    if (old_run_) try_rejoin();
    if (!backlog_.empty()) phase_ = Phase::Publish;  // a rejoin took steps back: their entries first
  }
  if (step_ % substeps_ != 0) return;
  if (!speculating()) {
    if (safety_.keep_states) kept_states_.emplace(step_, world_->part_snapshot());
    if (safety_.horizon) safety_.horizon->report(world_->id(), step_);
    if (safety_.keep_states)
      kept_states_.erase(kept_states_.begin(), kept_states_.lower_bound(safety_.horizon->gvt()));
  }
  if (progress_) progress_(step_ / substeps_);
  if (output_.after_step) output_.after_step(world_->id(), step_ / substeps_);
  // A re-run after a rollback (speculation) does not publish the steps up to
  // the changed one: their entries were kept, and the re-run reproduces them.
  if (output_.buffer && step_ / substeps_ >= next_publish_) {
    publish_current_ = true;
    phase_ = Phase::Publish;
  }
}

std::string PartitionedWorld::Process::waiting_for() const {
  std::ostringstream s;
  s << "world " << world_->id() << " at step " << step_ << " ";
  auto missing = [&](MessageKind kind, const std::vector<WorldId>& from) {
    s << "waits for " << message_kind_name(kind) << " from";
    for (WorldId n : from)
      if (!inbox_.count(Key{static_cast<int>(kind), step_, n})) s << " " << n;
  };
  switch (phase_) {
    case Phase::Predict: s << "is done (target " << target_ << ")"; break;
    case Phase::AwaitGhosts: missing(MessageKind::Ghosts, neighbours_); break;
    case Phase::AwaitGlue: {
      std::vector<WorldId> from;
      for (WorldId n : neighbours_)
        if (world_->sends_ghosts_to(n)) from.push_back(n);
      missing(MessageKind::Glue, from);
      break;
    }
    case Phase::Merging: s << "waits for island fragments"; break;
    case Phase::AwaitMigrants: missing(MessageKind::Migrants, neighbours_); break;
    case Phase::Publish: s << "waits for room in its transform buffer"; break;
  }
  if (speculating()) {
    s << "; horizon " << safety_.horizon->gvt();
  }
  return s.str();
}

WorldMetrics PartitionedWorld::Process::metrics() const {
  WorldMetrics m = sums_;
  m.steps = step_;
  // Finished steps only: a world parked at its limit may still be in
  // advance() (writing step_cpu_ns_) while a Simulation reads its metrics.
  m.cpu_seconds = static_cast<double>(cpu_ns_) * 1e-9;
  m.cpu_step_mean_ms = step_ ? static_cast<double>(cpu_ns_) * 1e-6 / static_cast<double>(step_) : 0.0;
  m.cpu_step_max_ms = static_cast<double>(step_cpu_max_ns_) * 1e-6;
  m.cpu_step_ms.reserve(step_cpu_history_ns_.size());
  for (std::int64_t ns : step_cpu_history_ns_) m.cpu_step_ms.push_back(static_cast<double>(ns) * 1e-6);
  m.blocked_seconds = static_cast<double>(blocked_ns_) * 1e-9;
  m.buffer_blocked_seconds = static_cast<double>(room_blocked_ns_) * 1e-9;
  m.entries_published = entries_published_;
  m.entries_dropped = entries_dropped_;
  m.owned_bodies = world_->owned_count();
  m.ghosts = world_->ghost_count();
  m.bets = bets_;
  m.bets_lost = bets_lost_;
  m.rollbacks = rollbacks_;
  m.steps_rolled_back = steps_rolled_back_;
  m.steps_rejoined = steps_rejoined_;
  m.bodies_resolved = bodies_resolved_;
  m.bodies_replayed = bodies_replayed_;
  m.rollback_cpu_seconds = static_cast<double>(rollback_cpu_ns_) * 1e-9;
  m.lead = lead_;
  double sum = 0;
  for (std::int32_t l : lead_) {
    sum += l;
    m.lead_max = std::max<std::int64_t>(m.lead_max, l);
  }
  m.lead_mean = lead_.empty() ? 0.0 : sum / static_cast<double>(lead_.size());
  m.kept_states_max = kept_max_;
  return m;
}

}  // namespace soda
