#include "step/world_process.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include "speculation/anticipation.h"
#include "speculation/lockstep.h"
#include "driver/metrics_sums.h"
#include "embedding/run_control.h"
#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/scene_reader.h"
#include "soda/scene/kinematic_command.h"
#include "execution/transport_bytes.h"
#include "step/spawned_groups.h"

namespace soda {

PartitionedWorld::Process::Process(TerritoryWorld& world, Transport& transport, const WorldGraph& graph,
                                   Validator* validator, std::function<void(std::int64_t)> progress, int substeps,
                                   bool solve_everywhere, Safety safety)
    : transport_(transport),
      graph_(graph),
      validator_(validator),
      progress_(std::move(progress)),
      substeps_(substeps),
      solve_everywhere_(solve_everywhere),
      neighbours_(graph.neighbours(world.id())),
      safety_(std::move(safety)) {
  s_.world = &world;
  s_.step = world.steps_done();
  sums_.world = world.id();
  sums_.neighbours = neighbours_.size();
  if (safety_.anticipation > 0) {
    spec_ = std::make_unique<Anticipation>(
        Anticipation::Context{s_, kept_, safety_, output_, neighbours_, validator_, substeps_, clock_});
  } else {
    spec_ = std::make_unique<Lockstep>(Lockstep::Context{s_, kept_, safety_, output_, validator_, substeps_, clock_});
  }
  if (safety_.keep_states || spec_->runs_ahead()) kept_.states().emplace(s_.step, world.part_snapshot());
}

// Inputs at this boundary, in sequence order; each world applies those that
// concern its territory (the owner of a body, the owner of a new body's home
// cell: a spawned group's anchor's), so that exactly one world applies each;
// a gravity change, a kinematic body's command and a collision filter (every
// copy of the body, every kept contact of it) concern every world, and each
// applies it at the same boundary.
void PartitionedWorld::Process::apply_inputs() {
  const std::vector<UserInput>& inputs = output_.inputs->at(s_.step / substeps_);
  const std::map<BodyId, Vec3> homes = spawned_group_homes(inputs);
  for (const UserInput& in : inputs) {
    switch (in.kind) {
      case UserInput::Kind::AddBody: {
        auto home = homes.find(in.body.id);
        s_.world->add_body(in.body, home == homes.end() ? nullptr : &home->second);
        break;
      }
      case UserInput::Kind::RemoveBody: s_.world->remove_body(in.id); break;
      case UserInput::Kind::SetVelocity: s_.world->set_velocity(in.id, in.linear, in.angular); break;
      case UserInput::Kind::ApplyImpulse: s_.world->apply_impulse(in.id, in.linear); break;
      case UserInput::Kind::SetGravity: s_.world->set_gravity(in.linear); break;  // every world
      case UserInput::Kind::SetMass: s_.world->set_mass(in.id, in.value); break;
      case UserInput::Kind::SetFriction: s_.world->set_friction(in.id, in.value); break;
      case UserInput::Kind::SetRestitution: s_.world->set_restitution(in.id, in.value); break;
      case UserInput::Kind::SetUserData: s_.world->set_user_data(in.id, in.user_data); break;
      case UserInput::Kind::SetPose:  // a kinematic body: every world; a dynamic one: its owner
        if (!s_.world->command_kinematic(in.id, kinematic_command(in)))
          s_.world->set_pose(in.id, Pose{in.linear, in.orientation});
        break;
      case UserInput::Kind::SetKinematicTarget:  // every world
        s_.world->command_kinematic(in.id, kinematic_command(in));
        break;
      case UserInput::Kind::RemoveJoint: s_.world->remove_joint(in.joint); break;  // the world holding it
      case UserInput::Kind::AddJoint: s_.world->add_joint(in.added_joint); break;  // the owner of its bodies
      case UserInput::Kind::SetJointMotor: s_.world->set_joint_motor(in.joint, in.motor); break;  // the same
      case UserInput::Kind::SetCollisionFilter:  // every world (its copies and kept contacts of the body)
        if (!s_.world->filter_kinematic(in.id, FilterCommand{in.step, in.collision_group, in.collision_mask}))
          s_.world->set_collision_filter(in.id, in.collision_group, in.collision_mask);
        break;
    }
  }
}

// After integrate, before anything of the step leaves the world: a bad state
// never reaches a neighbour.
void PartitionedWorld::Process::check_watchdog() {
  const std::int64_t scene_step = s_.step / substeps_ + 1;
  if (safety_.fault.step == scene_step && safety_.fault_fired && !safety_.fault_fired->load() &&
      s_.world->set_velocity(safety_.fault.body, Vec3::Constant(std::nan("")), Vec3::Zero()))
    safety_.fault_fired->store(true);
  if (!safety_.watchdog || safety_.watchdog->response == WatchdogResponse::Off) return;
  std::vector<WatchdogFinding> findings = s_.world->watchdog_findings(safety_.watchdog->limits);
  if (!findings.empty()) throw WatchdogError(scene_step, s_.world->id(), std::move(findings), safety_.watchdog->limits);
}

void PartitionedWorld::Process::deliver(Message m) {
  StageClock::Scope stage(clock_, Stage::Receive);
  clock_.count(Stage::Receive, 1);
  if (m.to != s_.world->id())
    throw std::logic_error("world " + std::to_string(s_.world->id()) + " got " + describe(m));
  const Control* control = std::get_if<Control>(&m.payload);
  if (control && control->type == Control::Type::Wake && m.from == m.to) return;  // it has woken us
  if (!graph_.adjacent(s_.world->id(), m.from))
    throw PartitionError("world " + std::to_string(s_.world->id()) + " got " + describe(m) +
                         " from a world that is not a neighbour");
  // Rewinds (messages.h): a message of a run this world has rewound is
  // void; one sent after a rewind this world has not taken yet (its sender
  // took it first) waits for it, and so does this world no longer.
  if (m.rewinds < rewinds_) return;
  if (m.rewinds > rewinds_ && !take_rewind())
    throw std::logic_error("world " + std::to_string(s_.world->id()) + " got " + describe(m) + " after " +
                           std::to_string(rewinds_) + " rewinds, with none pending");
  Verdict screened = spec_->screen(m);
  const bool drop = screened.drop;
  apply(std::move(screened));
  if (drop) return;
  if (m.kind() == MessageKind::Fragments || m.kind() == MessageKind::Results || m.kind() == MessageKind::Gather) {
    // Late fragments of a step whose merge is over are dropped: the island
    // they belong to is complete here (island_merge.h).
    const bool late = m.step < s_.step || (m.step == s_.step && s_.phase == StepPhase::AwaitMigrants);
    if (!late) s_.fragments[m.step].push_back(std::move(m));
    return;
  }
  if (m.step < s_.step) throw std::logic_error("world " + std::to_string(s_.world->id()) + " got a stale " + describe(m));
  const MessageKey key = message_key(m.kind(), m.step, m.from);
  if (s_.inbox.count(key)) throw std::logic_error("world " + std::to_string(s_.world->id()) + " got " + describe(m) + " twice");
  s_.inbox.emplace(key, std::move(m));
}

PartitionedWorld::Process::Advance PartitionedWorld::Process::advance() {
  // No scope around the whole call (a world polled with nothing to do would
  // pay two clock reads per poll): what no stage below takes is not counted.
  // A pending rollback first: the mailbox may already hold messages of the
  // re-run steps from neighbours that rewound before this world.
  apply(spec_->catch_up());
  take_rewind();
  // Fuzzing: a rewind may come now, and its first messages before this
  // world's mailbox is read (deliver takes it then).
  if (safety_.fuzz) fuzz_pause(*safety_.fuzz);
  Advance result;
  {
    // Opened at the first message: a call that finds none reads no clock.
    std::optional<StageClock::Scope> receive;
    for (Message& m : held_) {
      if (!receive) receive.emplace(clock_, Stage::Receive);
      deliver(std::move(m));
      result.progressed = result.progressed || spec_->runs_ahead();  // it may have confirmed a bet
    }
    held_.clear();
    while (std::optional<Message> m = transport_.try_receive(s_.world->id())) {
      if (!receive) receive.emplace(clock_, Stage::Receive);
      deliver(std::move(*m));
      result.progressed = result.progressed || spec_->runs_ahead();  // it may have confirmed a bet
    }
  }
  for (;;) {
    if (s_.phase == StepPhase::Predict && !may_start()) {
      // Held by readers (RunControl::hold_for_readers) while speculating: it
      // waits for the horizon, reading its mailbox (a rollback may come).
      if (spec_->runs_ahead() && output_.control) {
        if (const std::optional<std::int64_t> until = output_.control->held_until(s_.step)) {
          result.progressed = result.progressed || !spec_->wake_when_final(*until);
          break;
        }
      }
      // Speculating, the world is done only once no step of it can change:
      // once the commit horizon reaches its clock.
      result.done = spec_->done();
      break;
    }
    const std::int64_t before = s_.step;
    if (!run_phase()) break;
    result.progressed = true;
    if (s_.step != before) step_costs_done();
  }
  spec_->report_committed();
  return result;
}

bool PartitionedWorld::Process::have_all(MessageKind kind, const std::vector<WorldId>& from) const {
  for (WorldId n : from)
    if (!s_.inbox.count(message_key(kind, s_.step, n))) return false;
  return true;
}

template <class Batch>
std::vector<std::pair<WorldId, Batch>> PartitionedWorld::Process::take_all(MessageKind kind,
                                                                           const std::vector<WorldId>& from) {
  std::vector<std::pair<WorldId, Batch>> out;
  for (WorldId n : from) {
    auto it = s_.inbox.find(message_key(kind, s_.step, n));
    spec_->used(it->first, it->second);
    out.emplace_back(n, std::get<Batch>(std::move(it->second.payload)));
    s_.inbox.erase(it);
  }
  return out;
}

void PartitionedWorld::Process::send(WorldId to, Message message) {
  message.from = s_.world->id();
  message.to = to;
  message.step = s_.step;
  message.epoch = spec_->epoch();
  message.rewinds = rewinds_;
  spec_->sent(message);
  ++sums_.messages_sent;
  const std::uint64_t bytes0 = thread_bytes_sent();
  const MessageKind kind = message.kind();
  transport_.send(to, std::move(message));
  clock_.sent(to, kind, thread_bytes_sent() - bytes0);
}

// One case per place the step can wait; each reads as the stages it runs,
// in order, one call each (their TerritoryWorld calls: territory_world.h).
bool PartitionedWorld::Process::run_phase() {
  if (safety_.fuzz) fuzz_pause(*safety_.fuzz);
  switch (s_.phase) {
    case StepPhase::Predict:  // waits for: nothing (inputs of the boundary are at hand)
      predict();
      send_ghosts();
      s_.phase = StepPhase::AwaitGhosts;
      return true;
    case StepPhase::AwaitGhosts:  // waits for: Ghosts(t) of every neighbour (or bets on them)
      if (!have_or_bet(MessageKind::Ghosts)) return false;
      if (s_.idle && !woken()) {  // idle: no ghost for it, the step changes nothing here
        skip_idle_step();
        s_.phase = StepPhase::AwaitMigrants;
        return true;
      }
      exchange_ghosts();
      collide();
      build_islands();
      send_glue();
      s_.phase = StepPhase::AwaitGlue;
      return true;
    case StepPhase::AwaitGlue:  // waits for: Glue(t) of every neighbour it sent ghosts to
      if (!have_all(MessageKind::Glue, glue_senders())) return false;
      glue();
      s_.phase = StepPhase::Merging;
      return true;
    case StepPhase::Merging: {  // waits for: Fragments, Gather, Results(t) until its islands are solved
      const bool progressed = merge();  // solves the islands it is the root of
      if (!s_.merger.done() || !s_.islands.empty()) return progressed;
      integrate();
      send_migrants();
      s_.phase = StepPhase::AwaitMigrants;
      return true;
    }
    case StepPhase::AwaitMigrants:  // waits for: Migrants(t) of every neighbour (or bets on them)
      if (!have_or_bet(MessageKind::Migrants)) return false;
      migrate();  // ends the step
      return true;
    case StepPhase::Publish:  // waits for: room in the transform buffer
      return publish();
  }
  return false;
}

bool PartitionedWorld::Process::have_or_bet(MessageKind kind) {
  if (have_all(kind, neighbours_)) return true;
  apply(spec_->bet(kind));
  return have_all(kind, neighbours_);
}

std::vector<WorldId> PartitionedWorld::Process::glue_senders() const {
  std::vector<WorldId> from;
  for (WorldId n : neighbours_)
    if (s_.world->sends_ghosts_to(n)) from.push_back(n);
  return from;
}

void PartitionedWorld::Process::predict() {
  StageClock::Scope stage(clock_, Stage::Predict);
  if (output_.inputs && s_.step % substeps_ == 0) apply_inputs();
  apply(spec_->before_predict());
  s_.idle = safety_.skip_idle && !fault_due() && s_.world->idle_ready();
  if (s_.idle) {
    s_.world->begin_idle_step();
  } else {
    s_.world->predict();
  }
}

// Idle territories (docs/skip.md): the injected fault of a test is due at
// the end of this step (check_watchdog): the step is not skipped.
bool PartitionedWorld::Process::fault_due() const {
  return safety_.fault_fired && !safety_.fault_fired->load() && safety_.fault.step == s_.step / substeps_ + 1;
}

// An idle step whose Ghosts (had or bet on) hold something wakes: predict()
// now writes what it would have written at the step's start (every owned
// body is settled, no input came) and finds no ghost to send, as the empty
// Ghosts already sent said.
bool PartitionedWorld::Process::woken() {
  bool touched = false;
  for (WorldId n : neighbours_) {
    const GhostBatch& b = std::get<GhostBatch>(s_.inbox.at(message_key(MessageKind::Ghosts, s_.step, n)).payload);
    touched = touched || !b.ghosts.empty() || !b.kept_manifolds.empty();
  }
  if (!touched) return false;
  StageClock::Scope stage(clock_, Stage::Predict);
  s_.idle = false;
  s_.world->predict();
  for (WorldId n : neighbours_)
    if (s_.world->sends_ghosts_to(n))
      throw std::logic_error("world " + std::to_string(s_.world->id()) + ", step " + std::to_string(s_.step) +
                             ": a woken idle step has ghosts for world " + std::to_string(n));
  return true;
}

// The rest of an idle step up to the migrants: the neighbours' (empty)
// Ghosts taken, nothing collided, solved or integrated, no body leaves.
// Counted as migrate, both parts (one stage: two clock reads fewer, and an
// idle step's cost is mostly clock reads and messages).
void PartitionedWorld::Process::skip_idle_step() {
  StageClock::Scope stage(clock_, Stage::Migrate);
  take_all<GhostBatch>(MessageKind::Ghosts, neighbours_);
  ++sums_.idle_steps;
  for (WorldId n : neighbours_) send(n, Message{.payload = MigrantBatch{}});
}

void PartitionedWorld::Process::send_ghosts() {
  StageClock::Scope stage(clock_, Stage::ExchangeGhosts);
  for (WorldId n : neighbours_) send(n, Message{.payload = s_.world->ghost_batch_for(n)});
}

void PartitionedWorld::Process::exchange_ghosts() {
  StageClock::Scope stage(clock_, Stage::ExchangeGhosts);
  s_.world->apply_ghosts(take_all<GhostBatch>(MessageKind::Ghosts, neighbours_), spec_->runs_ahead());
}

void PartitionedWorld::Process::collide() {
  StageClock::Scope stage(clock_, Stage::Collide);
  s_.world->collide();
}

void PartitionedWorld::Process::build_islands() {
  StageClock::Scope stage(clock_, Stage::BuildIslands);
  s_.world->build_islands();
}

void PartitionedWorld::Process::send_glue() {
  StageClock::Scope stage(clock_, Stage::Glue);
  for (WorldId n : neighbours_)
    if (s_.world->received_ghosts_from(n)) send(n, Message{.payload = s_.world->glue_batch_for(n)});
}

void PartitionedWorld::Process::glue() {
  StageClock::Scope stage(clock_, Stage::Glue);
  s_.merger.start(s_.world->id(), s_.world->border_fragments(take_all<GlueBatch>(MessageKind::Glue, glue_senders())),
                solve_everywhere_);
  StageClock::Scope merge(clock_, Stage::Merge);
  flush_merger();
}

// The merge messages of this step at hand, in order of arrival.
bool PartitionedWorld::Process::merge() {
  StageClock::Scope stage(clock_, Stage::Merge);
  auto it = s_.fragments.find(s_.step);
  if (it == s_.fragments.end()) return false;
  std::vector<Message> batch = std::move(it->second);
  s_.fragments.erase(it);
  for (Message& m : batch) {
    ++sums_.relay_messages_received;
    spec_->merged();
    if (m.kind() == MessageKind::Results) {
      for (std::shared_ptr<const IslandResult>& r : std::get<ResultBatch>(m.payload).results)
        take_result(std::move(r));
    } else if (m.kind() == MessageKind::Gather) {
      GatherBatch& g = std::get<GatherBatch>(m.payload);
      take_gather(g.island, std::move(g.fragments));
    } else if (!s_.merger.done()) {
      s_.merger.receive(m.from, std::get<FragmentBatch>(std::move(m.payload)).fragments);
    }
    flush_merger();
  }
  return true;
}

void PartitionedWorld::Process::integrate() {
  StageClock::Scope stage(clock_, Stage::Integrate);
  if (!s_.early_gathers.empty())
    throw std::logic_error("world " + std::to_string(s_.world->id()) + ": data for an island it is not in");
  sums_.fragments_relayed += s_.merger.fragments_relayed();
  s_.world->finish_islands();
  s_.world->integrate();
  check_watchdog();
}

void PartitionedWorld::Process::send_migrants() {
  StageClock::Scope stage(clock_, Stage::Migrate);
  for (auto& [n, batch] : s_.world->migrate()) send(n, Message{.payload = std::move(batch)});
}

void PartitionedWorld::Process::migrate() {
  StageClock::Scope stage(clock_, Stage::Migrate);
  s_.world->absorb_migrants(take_all<MigrantBatch>(MessageKind::Migrants, neighbours_));
  end_step();
}

bool PartitionedWorld::Process::publish() {
  StageClock::Scope stage(clock_, Stage::Publish);
  return try_publish();
}

bool PartitionedWorld::Process::may_start() {
  return output_.control ? output_.control->may_start(s_.world->id(), s_.step) : s_.step < target_;
}

void PartitionedWorld::Process::end_step() {
  const TerritoryCounters& c = s_.world->counters();
  add_step_counters(sums_, c);
  clock_.count(Stage::Predict, c.owned_bodies);
  clock_.count(Stage::ExchangeGhosts, c.ghosts_received);
  clock_.count(Stage::Collide, c.held_manifolds);
  clock_.count(Stage::BuildIslands, c.local_islands);
  clock_.count(Stage::Glue, c.border_fragments);
  clock_.count(Stage::Solve, c.islands_solved);
  clock_.count(Stage::Integrate, s_.world->owned_count() - s_.world->parked_count());  // parked bodies are not
  clock_.count(Stage::Migrate, c.migrations_in + c.migrations_out);
  ++s_.step;
  s_.phase = StepPhase::Predict;
  if (validator_) {
    WorldStepReport report{s_.world->id(),           s_.step,
                           s_.world->owned_ids(),    s_.world->ghost_count(),
                           s_.world->held_static_count(), s_.world->bullet_object_count(),
                           s_.world->held_contact_pairs(), s_.world->parked_count()};
    spec_->report(std::move(report));
  }
  apply(spec_->step_ended(c));  // lockstep: keeps states at scene step boundaries
  if (s_.step % substeps_ != 0) return;
  if (progress_) progress_(s_.step / substeps_);
  if (output_.after_step) output_.after_step(s_.world->id(), s_.step / substeps_);
  // A re-run after a rollback (speculation) does not publish the steps up to
  // the changed one: their entries were kept, and the re-run reproduces them.
  if (output_.buffer && s_.step / substeps_ >= s_.next_publish) {
    s_.publish_current = true;
    s_.phase = StepPhase::Publish;
  }
}

}  // namespace soda
