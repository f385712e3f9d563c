// One world's speculation (anticipation.h, docs/rollback.md): its hooks,
// bets on empty neighbour messages, the messages it used, rollback notices,
// rollbacks of every world, and its low-water mark in the commit horizon.
// Restores, rejoins and replays: anticipation_rollback.cpp. Every change to
// the step goes into the verdict of the hook running (out()).
//
// Why the result equals lockstep's: a world's step t is a function of its
// state at t and the neighbours' messages of t it uses. Every message it used
// is kept until GVT passes its step; a message that was assumed (a bet) or
// that its sender has voided (a Notice) counts as unconfirmed and holds the
// world's low-water mark at its step. When the final version of a message
// arrives it is compared, as bytes, with the one used; a difference restores
// the world's own kept state of that step and re-runs from there with the new
// message; Glue without entries (no island crosses the border) is kept and
// compared the same way, with whatever its sender sends again in its place:
// a sender's re-run may find an island across the border that its first run
// had not, and its Glue, empty before, holds entries now. Merge messages
// (Glue with entries, Fragments, Gather, Results) are not kept: a merged
// island is re-merged by all its worlds, so a rollback over a step with
// merge messages is one of every world (rollback_board.h), after which no
// message of the old run of those steps is used. When no message can change
// any more (GVT at the clock) every world has run every step on the final
// messages, which is the lockstep run.
//
// Why it ends: every rollback starts from a lost bet (a message that turned
// out not empty; that bet is never placed again) or from a message that
// changed because of one; re-runs on equal messages send equal messages,
// which roll nobody back.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "embedding/run_control.h"
#include "soda/runtime/message_codec.h"
#include "speculation/anticipation.h"

namespace soda {

bool is_merge_message(const Message& m) {
  switch (m.kind()) {
    case MessageKind::Glue: return !std::get<GlueBatch>(m.payload).entries.empty();
    case MessageKind::Fragments:
    case MessageKind::Gather:
    case MessageKind::Results: return true;
    default: return false;
  }
}

Anticipation::Anticipation(Context c)
    : c_(std::move(c)),
      s_(c_.step),
      // A state every checkpoint_every internal steps (a rollback restores
      // the one at or before the step and re-runs the rest); every step if
      // kept states are asked for anyway.
      checkpoint_every_(c_.safety.keep_states ? 1 : c_.safety.checkpoint_every) {}


Verdict& Anticipation::out() {
  if (!out_) throw std::logic_error("Anticipation: a change to the step outside a hook");
  return *out_;
}

std::int64_t Anticipation::at_step() const { return out_ && out_->restart ? out_->restart->step : s_.step; }

StepPhase Anticipation::at_phase() const {
  return out_ && out_->restart ? StepPhase::Predict : s_.phase;
}

Verdict Anticipation::screen(Message& m) {
  Verdict v;
  Building building(*this, v);
  v.drop = screen_into(m);
  return v;
}

Verdict Anticipation::catch_up() {
  Verdict v;
  Building building(*this, v);
  catch_up_into();
  return v;
}

bool Anticipation::screen_into(Message& m) {
  if (m.epoch > seen_epoch_) {  // a rollback of every world its sender saw first
    c_.safety.board->await(m.epoch);  // over ranks its entry may still be on its way
    catch_up_into();
  }
  if (const Control* control = std::get_if<Control>(&m.payload)) {
    // The sender's pin holds the horizon at the notice's step until this
    // world's mark covers the uses the notice voids (take_notice reports
    // it): released first, the horizon could pass the step meanwhile and a
    // world trim the states a rollback to it needs (docs/rollback.md).
    if (!c_.safety.board->voids(m.epoch, control->rolled_to, seen_epoch_)) take_notice(m.from, control->rolled_to);
    c_.safety.horizon->unpin(control->pinned);  // pinned by its sender
    return true;
  }
  if (c_.safety.board->voids(m.epoch, m.step, seen_epoch_)) return true;
  if (m.kind() == MessageKind::Ghosts) {
    auto [it, fresh] = newest_ghosts_.try_emplace(m.from, m.step, false);
    if (fresh || m.step >= it->second.first) it->second = {m.step, !std::get<GhostBatch>(m.payload).ghosts.empty()};
  }
  // Every message with a use on record is compared, a merge message too: a
  // Glue with entries sent again for an empty one used here (its sender's
  // re-run found an island across the border its first run had not).
  if (compare_with_used(m)) return true;
  // Glue of a step whose glue this world no longer waits for: not needed
  // (a neighbour re-sent it after rolling back).
  const std::int64_t step = at_step();
  const StepPhase phase = at_phase();
  return m.kind() == MessageKind::Glue &&
         (m.step < step || (m.step == step && phase != StepPhase::Predict && phase != StepPhase::AwaitGhosts &&
                            phase != StepPhase::AwaitGlue));
}

Verdict Anticipation::before_predict() {
  Verdict v;
  Building building(*this, v);
  if (old_run_ || partial_step_) arm_replay();
  return v;
}

void Anticipation::sent(const Message& m) {
  if (is_merge_message(m)) {
    merge_steps_.insert(s_.step);
  } else if (m.kind() != MessageKind::Control) {
    sent_log_[s_.step].push_back(m);  // re-sent if a re-run rejoins the run that sent it
  }
}

void Anticipation::report(WorldStepReport report) {
  if (s_.step > reported_through_) reports_.insert_or_assign(s_.step, std::move(report));  // once committed
}

Verdict Anticipation::step_ended(const TerritoryCounters& c) {
  Verdict v;
  Building building(*this, v);
  StageClock::Scope stage(c_.clock, Stage::Checkpoint);
  if (partial_step_ && partial_step_->step < s_.step) partial_step_.reset();
  if (s_.step <= rerun_until_) {
    bodies_resolved_ += s_.world->owned_count() - std::min(s_.world->owned_count(), c.bodies_replayed);
    bodies_replayed_ += c.bodies_replayed;
  }
  // Replaying a re-run (arm_replay) needs the islands of every step a
  // rollback may restore.
  if (!c_.safety.recompute) island_log_[s_.step - 1] = s_.world->local_islands();
  if (s_.step % checkpoint_every_ == 0) {
    c_.kept.keep(s_.step, *s_.world);
    c_.clock.count(Stage::Checkpoint, 1);
  }
  c_.kept.noted();
  report_mark();
  const std::int64_t gvt = c_.safety.horizon->gvt();
  lead_.push_back(static_cast<std::int32_t>(s_.step - gvt));
  trim_below(gvt);
  if (old_run_) try_rejoin();  // its backlog, if any, is published first
  return v;
}

bool Anticipation::done() { return !c_.safety.horizon->wake_at(me(), s_.step); }

bool Anticipation::wake_when_final(std::int64_t scene_step) {
  return c_.safety.horizon->wake_at(me(), scene_step * c_.substeps);
}

void Anticipation::published(std::int64_t scene_step) {
  last_published_ = scene_step;
  report_committed();
}

// Under a Simulation: entries above the commit horizon may still be
// rewritten. The buffer's commit step follows GVT (one behind the newest
// entry, which stays readable), and the RunControl hears only of committed
// steps, so advance_to() and the readouts never see a speculative state.
void Anticipation::report_committed() {
  if (!c_.output.control) return;
  const std::int64_t horizon = c_.safety.horizon->gvt() / c_.substeps;
  const std::int64_t commit = std::min(last_published_ - 1, horizon - 1);
  c_.output.buffer->raise_commit_step(commit);
  // Readers' holds keep entries and states for inputs at their frames, not
  // the worlds' own speculation: what is committed leaves them out.
  const std::int64_t committed =
      std::min(last_published_, c_.safety.horizon->gvt_without_readers() / c_.substeps);
  if (committed > committed_reported_) {
    committed_reported_ = committed;
    c_.output.control->published(me(), committed);
  }
}

void Anticipation::step_cpu(std::int64_t ns) {
  if (s_.step <= rerun_until_) rerun_cpu_ns_ += ns;
}

// Rewound from outside: every world parked at one boundary, nothing in
// flight; the logs of later steps go (the kept states: KeptStates, by the step).
void Anticipation::reset(std::int64_t step) {
  used_.clear();
  sent_log_.clear();
  island_log_.clear();
  old_run_.reset();
  partial_step_.reset();
  unconfirmed_.clear();
  bets_in_inbox_.clear();
  merge_steps_.clear();
  reports_.erase(reports_.upper_bound(step), reports_.end());
}

void Anticipation::metrics(WorldMetrics& m) const {
  m.bets = bets_;
  m.bets_lost = bets_lost_;
  m.rollbacks = rollbacks_;
  m.steps_rolled_back = steps_rolled_back_;
  m.steps_rejoined = steps_rejoined_;
  m.bodies_resolved = bodies_resolved_;
  m.bodies_replayed = bodies_replayed_;
  m.rollback_cpu_seconds = static_cast<double>(rerun_cpu_ns_) * 1e-9;
  m.lead = lead_;
  double sum = 0;
  for (std::int32_t l : lead_) {
    sum += l;
    m.lead_max = std::max<std::int64_t>(m.lead_max, l);
  }
  m.lead_mean = lead_.empty() ? 0.0 : sum / static_cast<double>(lead_.size());
}


// Neighbour `from` rolled back to `step` on its own (it had no merge
// messages from that step on): its messages of steps >= step sent before
// this are void. Drops those not used yet; the ones used await their
// re-send, which is compared with them.
void Anticipation::take_notice(WorldId from, std::int64_t step) {
  SPEC_TRACE("w%d at %lld: notice from %d: rolled back to %lld\n", me(), (long long)at_step(), from,
             (long long)step);
  // Fuzzing: other worlds run on while this one takes the notice in (the
  // horizon must not move past the notice's step meanwhile: screen()).
  if (c_.safety.fuzz) fuzz_pause(*c_.safety.fuzz);
  InboxEdit drop{.kind = InboxEdit::Kind::DropFrom};
  drop.from = from;
  drop.step = step;
  out().inbox.push_back(std::move(drop));
  std::erase_if(bets_in_inbox_, [&](const MessageKey& k) { return std::get<2>(k) == from && std::get<1>(k) >= step; });
  for (auto it = used_.lower_bound(UsedKey{step, 0, kNoWorld}); it != used_.end(); ++it) {
    const auto& [s, kind, f] = it->first;
    Used& u = it->second;
    if (f == from && u.confirmed) await_resend(s, u);
  }
  report_mark();
}

// A message used at `step` changed: this world's own rollback if it had no
// merge messages from `step` on (and not recomputing), else every world's.
// The world goes back to its checkpoint at or before `step`.
void Anticipation::roll_back(std::int64_t step) {
  if (step < c_.safety.horizon->gvt())
    throw std::logic_error("world " + std::to_string(me()) + ": rollback to step " + std::to_string(step) +
                           ", below the commit horizon " + std::to_string(c_.safety.horizon->gvt()));
  const std::int64_t back = checkpoint_at_or_before(step);
  const bool merged = merge_steps_.lower_bound(back) != merge_steps_.end();
  if (merged || c_.safety.recompute) {
    SPEC_TRACE("w%d at %lld: posts a rollback of every world to %lld\n", me(), (long long)at_step(),
               (long long)back);
    c_.safety.board->post(back, step, me());
    catch_up_into();
    return;
  }
  restore(back, step, true);
  for (WorldId n : c_.neighbours) {
    if (!c_.safety.horizon->try_pin(step))
      throw std::logic_error("world " + std::to_string(me()) + ": rolled back below the commit horizon");
    Message notice;
    notice.payload = Control{Control::Type::Notice, ++notices_sent_[n], back, step};
    out().send.emplace_back(n, std::move(notice));  // after the restart: stamped with its step
  }
}

// Checkpoints are kept at internal steps that are multiples of
// checkpoint_every_ (the same steps in every world), and at the first step.
std::int64_t Anticipation::checkpoint_at_or_before(std::int64_t step) const {
  auto it = c_.kept.states().upper_bound(step);
  if (it == c_.kept.states().begin())
    throw std::logic_error("world " + std::to_string(me()) + ": no state kept at or before step " +
                           std::to_string(step));
  return std::prev(it)->first;
}

// Rollbacks of every world this world has not taken in yet: restore each
// step it has passed, drop every message their epochs voided.
void Anticipation::catch_up_into() {
  for (const RollbackBoard::Entry& e : c_.safety.board->since(seen_epoch_)) {
    // Rollback and Propagate: the world keeps its old run, which its re-run
    // rejoins if its own state and messages turn out unchanged.
    if (at_step() > e.step || (at_step() == e.step && at_phase() != StepPhase::Predict)) {
      restore(e.step, e.pinned, !c_.safety.recompute);
      // An input at a step readers hold may reach below what was committed:
      // the re-run reports its steps again (RunControl::rolled_back).
      committed_reported_ = std::min(committed_reported_, e.step / c_.substeps);
    }
    seen_epoch_ = e.epoch;
    auto void_message = [&](const Message& m) { return m.epoch < e.epoch && m.step >= e.step; };
    InboxEdit drop{.kind = InboxEdit::Kind::DropVoid};  // the inbox (not the bets) and the merge queue
    drop.step = e.step;
    drop.epoch = e.epoch;
    drop.keep = bets_in_inbox_;
    out().inbox.push_back(std::move(drop));
    for (auto it = used_.lower_bound(UsedKey{e.step, 0, kNoWorld}); it != used_.end(); ++it) {
      Used& u = it->second;  // used at a step this world had not passed: void, awaiting the re-send
      if (u.confirmed && u.message && void_message(*u.message)) await_resend(std::get<0>(it->first), u);
    }
    report_mark();  // before the pin goes (as for a Notice: screen)
    c_.safety.horizon->unpin(e.pinned);
  }
  report_mark();
}

// A used message its sender voided (a Notice, a rollback of every world):
// kept as a digest, unconfirmed, until the re-send is compared with it.
void Anticipation::await_resend(std::int64_t step, Used& u) {
  u.confirmed = false;
  u.digest = message_digest(*u.message);
  u.message.reset();
  ++unconfirmed_[step];
}

// Low-water mark: the clock, or the oldest step of a message used that may
// still change.
void Anticipation::report_mark() {
  std::int64_t mark = at_step();
  if (!unconfirmed_.empty()) mark = std::min(mark, unconfirmed_.begin()->first);
  c_.safety.horizon->report(me(), mark);
}

// Nothing below GVT can change: states, uses and validation reports of
// those steps are final.
void Anticipation::trim_below(std::int64_t gvt) {
  // A rollback to a step at or above GVT restores the checkpoint at or
  // before it and re-runs from there with the messages used: keep both.
  const std::int64_t keep = checkpoint_at_or_before(gvt);
  for (auto it = c_.kept.states().begin(); it != c_.kept.states().end() && it->first < keep; it = c_.kept.states().erase(it))
    c_.kept.recycle(std::move(it->second));
  used_.erase(used_.begin(), used_.lower_bound(UsedKey{keep, 0, kNoWorld}));
  sent_log_.erase(sent_log_.begin(), sent_log_.lower_bound(keep));
  island_log_.erase(island_log_.begin(), island_log_.lower_bound(keep));
  merge_steps_.erase(merge_steps_.begin(), merge_steps_.lower_bound(keep));
  std::erase_if(lost_bets_, [keep](const MessageKey& k) { return std::get<1>(k) < keep; });
  if (c_.validator) {
    auto end = reports_.upper_bound(gvt);
    for (auto it = reports_.begin(); it != end; ++it) {
      c_.validator->report(std::move(it->second));
      reported_through_ = it->first;
    }
    reports_.erase(reports_.begin(), end);
  }
}

}  // namespace soda
