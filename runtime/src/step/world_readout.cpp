// One world's readouts (world_process.h): its costs per stage (StageClock),
// its metrics, what it waits for.
#include <algorithm>
#include <sstream>

#include "step/world_process.h"

namespace soda {

// A step ended (or a rejoin took steps back): its CPU time is complete and
// the costs so far become the metrics (read by other threads: metrics()).
void PartitionedWorld::Process::step_costs_done() {
  clock_.publish();
  const StageClock::Totals& t = clock_.published();
  const std::int64_t step_ns = t.cpu_ns_sum - step_start_cpu_ns_;
  const std::int64_t rollback_ns = t.cpu_ns[static_cast<std::size_t>(Stage::Rollback)];
  step_cpu_max_ns_ = std::max(step_cpu_max_ns_, step_ns);
  step_cpu_history_ns_.push_back(step_ns);
  spec_->step_cpu(step_ns - (rollback_ns - step_start_rollback_ns_));  // restores: counted
  step_start_cpu_ns_ = t.cpu_ns_sum;
  step_start_rollback_ns_ = rollback_ns;
  if (!output_.control) {  // PartitionedWorld::step: its per-step loads
    const TerritoryCounters& c = s_.world->counters();
    const std::int64_t lead = spec_->runs_ahead() ? s_.step - safety_.horizon->gvt() : 0;
    step_log_.push_back(StepRecord{s_.step, step_ns, blocked_ns_ - step_start_blocked_ns_,
                                   static_cast<std::int32_t>(s_.world->owned_count()), static_cast<std::int32_t>(lead),
                                   static_cast<std::int32_t>(c.local_islands + c.islands_solved)});
  }
  step_start_blocked_ns_ = blocked_ns_;
}

// The stage a world waiting in s_.phase waits for.
Stage PartitionedWorld::Process::waiting_stage() const {
  switch (s_.phase) {
    case StepPhase::Predict: return Stage::Idle;
    case StepPhase::AwaitGhosts: return Stage::ExchangeGhosts;
    case StepPhase::AwaitGlue: return Stage::Glue;
    case StepPhase::Merging: return Stage::Merge;
    case StepPhase::AwaitMigrants: return Stage::Migrate;
    case StepPhase::Publish: return Stage::Publish;
  }
  return Stage::Idle;
}

void PartitionedWorld::Process::add_blocked_ns(std::int64_t ns) {
  blocked_ns_ += ns;
  clock_.add_wait(waiting_stage(), ns);
}

void PartitionedWorld::Process::add_guest_work(std::int64_t tasks, std::int64_t busy_ns) {
  guest_tasks_ += static_cast<std::uint64_t>(tasks);
  clock_.add_cpu(Stage::Solve, busy_ns);
}

std::string PartitionedWorld::Process::waiting_for() const {
  std::ostringstream s;
  s << "world " << s_.world->id() << " at step " << s_.step << " ";
  auto missing = [&](MessageKind kind, const std::vector<WorldId>& from) {
    s << "waits for " << message_kind_name(kind) << " from";
    for (WorldId n : from)
      if (!s_.inbox.count(message_key(kind, s_.step, n))) s << " " << n;
  };
  switch (s_.phase) {
    case StepPhase::Predict: s << "is done (target " << target_ << ")"; break;
    case StepPhase::AwaitGhosts: missing(MessageKind::Ghosts, neighbours_); break;
    case StepPhase::AwaitGlue: {
      std::vector<WorldId> from;
      for (WorldId n : neighbours_)
        if (s_.world->sends_ghosts_to(n)) from.push_back(n);
      missing(MessageKind::Glue, from);
      break;
    }
    case StepPhase::Merging: {
      s << "waits for island fragments: " << s_.merger.describe_open();
      for (const auto& [island, is] : s_.islands)
        s << "; island " << island << " (root " << is.root << ", parent " << is.parent << ") "
          << is.gathers_missing << " gathers missing";
      break;
    }
    case StepPhase::AwaitMigrants: missing(MessageKind::Migrants, neighbours_); break;
    case StepPhase::Publish: s << "waits for room in its transform buffer"; break;
  }
  if (spec_->runs_ahead()) {
    s << "; horizon " << safety_.horizon->gvt();
  }
  s << "; rewinds " << rewinds_ << "; inbox";
  for (const auto& [key, m] : s_.inbox) s << " " << describe(m);
  for (const auto& [step, ms] : s_.fragments)
    for (const Message& m : ms) s << " " << describe(m);
  return s.str();
}

WorldMetrics PartitionedWorld::Process::metrics() const {
  std::lock_guard lock(activity_);
  WorldMetrics m = sums_;
  m.steps = s_.step;
  // Finished steps only: a world parked at its limit may still be in
  // advance() (writing step_cpu_ns_) while a Simulation reads its metrics.
  const StageClock::Totals& t = clock_.published();
  m.cpu_seconds = static_cast<double>(t.cpu_ns_sum) * 1e-9;
  m.thread_cpu_seconds = static_cast<double>(t.thread_cpu_ns) * 1e-9;
  m.cpu_step_mean_ms = s_.step ? static_cast<double>(t.cpu_ns_sum) * 1e-6 / static_cast<double>(s_.step) : 0.0;
  const std::array<std::int64_t, kStageCount>& waits = clock_.waits();
  for (std::size_t i = 0; i < kStageCount; ++i) {
    StageCost& c = m.stages[i];
    c.cpu_seconds = static_cast<double>(t.cpu_ns[i]) * 1e-9;
    c.wait_seconds = static_cast<double>(waits[i]) * 1e-9;
    c.items = t.items[i];
    c.messages = t.messages[i];
    c.bytes = t.bytes[i];
  }
  m.traffic = clock_.published_traffic();
  m.cpu_step_max_ms = static_cast<double>(step_cpu_max_ns_) * 1e-6;
  m.cpu_step_ms.reserve(step_cpu_history_ns_.size());
  for (std::int64_t ns : step_cpu_history_ns_) m.cpu_step_ms.push_back(static_cast<double>(ns) * 1e-6);
  m.blocked_seconds = static_cast<double>(blocked_ns_) * 1e-9;
  m.guest_tasks = guest_tasks_;
  m.buffer_blocked_seconds = static_cast<double>(room_blocked_ns_) * 1e-9;
  m.entries_published = entries_published_;
  m.entries_dropped = entries_dropped_;
  m.owned_bodies = s_.world->owned_count();
  m.ghosts = s_.world->ghost_count();
  m.statics_held = s_.world->held_static_count();
  m.kept_states_max = kept_.max();
  spec_->metrics(m);
  m.rollback_cpu_seconds += static_cast<double>(t.cpu_ns[static_cast<std::size_t>(Stage::Rollback)]) * 1e-9;
  return m;
}

}  // namespace soda
