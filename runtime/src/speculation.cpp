// One world's speculation (speculation.h, docs/rollback.md): its hooks, bets
// on empty neighbour messages, the messages it used, rollback notices,
// rollbacks of every world, and its low-water mark in the commit horizon.
// Restores, rejoins and replays: speculation_rollback.cpp.
//
// Why the result equals lockstep's: a world's step t is a function of its
// state at t and the neighbours' messages of t it uses. Every message it used
// is kept until GVT passes its step; a message that was assumed (a bet) or
// that its sender has voided (a Notice) counts as unconfirmed and holds the
// world's low-water mark at its step. When the final version of a message
// arrives it is compared, as bytes, with the one used; a difference restores
// the world's own kept state of that step and re-runs from there with the new
// message; Glue without entries (no island crosses the border) is kept and
// compared the same way. Merge messages (Glue with entries, Fragments, Gather,
// Results) are not compared: a merged island is re-merged by all its worlds,
// so a rollback over a step with merge messages is one of every world
// (rollback_board.h), after which no message of the old run of those steps
// is used. When no message can change any more (GVT at the clock) every
// world has run every step on the final messages, which is the lockstep run.
//
// Why it ends: every rollback starts from a lost bet (a message that turned
// out not empty; that bet is never placed again) or from a message that
// changed because of one; re-runs on equal messages send equal messages,
// which roll nobody back.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "run_control.h"
#include "soda/runtime/message_codec.h"
#include "speculation.h"

namespace soda {
namespace {

Message empty_message(MessageKind kind, WorldId from, WorldId to, std::int64_t step) {
  Message m;
  m.from = from;
  m.to = to;
  m.step = step;
  if (kind == MessageKind::Ghosts) {
    m.payload = GhostBatch{};
  } else {
    m.payload = MigrantBatch{};
  }
  return m;
}

}  // namespace

bool is_merge_message(const Message& m) {
  switch (m.kind()) {
    case MessageKind::Glue: return !std::get<GlueBatch>(m.payload).entries.empty();
    case MessageKind::Fragments:
    case MessageKind::Gather:
    case MessageKind::Results: return true;
    default: return false;
  }
}

Speculation::Speculation(Context c)
    : c_(std::move(c)),
      s_(c_.step),
      // A state every checkpoint_every internal steps (a rollback restores
      // the one at or before the step and re-runs the rest); every step if
      // kept states are asked for anyway.
      checkpoint_every_(c_.safety.keep_states ? 1 : c_.safety.checkpoint_every) {}

bool Speculation::screen(Message& m) {
  if (m.epoch > seen_epoch_) {  // a rollback of every world its sender saw first
    c_.safety.board->await(m.epoch);  // over ranks its entry may still be on its way
    catch_up();
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
  if (!is_merge_message(m) && compare_with_used(m)) return true;
  // Glue of a step whose glue this world no longer waits for: not needed
  // (a neighbour re-sent it after rolling back).
  return m.kind() == MessageKind::Glue &&
         (m.step < s_.step || (m.step == s_.step && s_.phase != StepPhase::Predict &&
                               s_.phase != StepPhase::AwaitGhosts && s_.phase != StepPhase::AwaitGlue));
}

void Speculation::before_predict() {
  if (old_run_ || partial_step_) arm_replay();
}

void Speculation::sent(const Message& m) {
  if (is_merge_message(m)) {
    merge_steps_.insert(s_.step);
  } else if (m.kind() != MessageKind::Control) {
    sent_log_[s_.step].push_back(m);  // re-sent if a re-run rejoins the run that sent it
  }
}

void Speculation::report(WorldStepReport report) {
  if (s_.step > reported_through_) reports_.insert_or_assign(s_.step, std::move(report));  // once committed
}

void Speculation::step_ended(const TerritoryCounters& c) {
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
  if (old_run_) try_rejoin();
  if (!s_.backlog.empty()) s_.phase = StepPhase::Publish;  // a rejoin took steps back: their entries first
}

bool Speculation::done() { return !c_.safety.horizon->wake_at(me(), s_.step); }

bool Speculation::wake_when_final(std::int64_t scene_step) {
  return c_.safety.horizon->wake_at(me(), scene_step * c_.substeps);
}

void Speculation::published(std::int64_t scene_step) {
  last_published_ = scene_step;
  report_committed();
}

// Under a Simulation: entries above the commit horizon may still be
// rewritten. The buffer's commit step follows GVT (one behind the newest
// entry, which stays readable), and the RunControl hears only of committed
// steps, so advance_to() and the readouts never see a speculative state.
void Speculation::report_committed() {
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

void Speculation::step_cpu(std::int64_t ns) {
  if (s_.step <= rerun_until_) rerun_cpu_ns_ += ns;
}

// Rewound from outside: every world parked at one boundary, nothing in
// flight; the logs of later steps go (the kept states: KeptStates, by the step).
void Speculation::reset(std::int64_t step) {
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

void Speculation::metrics(WorldMetrics& m) const {
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

// The neighbours whose `kind` of this step is missing: bet that it is empty,
// if every one of them is a neighbour this world sent no ghosts to (and, for
// Migrants, got no ghosts from), no bet on it was lost at this step, the
// newest ghosts that arrived from it were empty unless bets are eager (a
// border that has just become busy stays busy: betting on each following
// step lost one bet and re-ran the world each time), and the step is within
// the anticipation.
bool Speculation::bet(MessageKind kind) {
  std::vector<WorldId> missing;
  for (WorldId n : c_.neighbours)
    if (!s_.inbox.count(message_key(kind, s_.step, n))) missing.push_back(n);
  for (WorldId n : missing) {
    if (s_.world->sends_ghosts_to(n)) return false;
    if (kind == MessageKind::Migrants && s_.world->received_ghosts_from(n)) return false;
    if (lost_bets_.count(message_key(kind, s_.step, n))) return false;
    auto newest = newest_ghosts_.find(n);
    if (!c_.safety.eager_bets && newest != newest_ghosts_.end() && newest->second.second) return false;
  }
  if (!within_anticipation()) return false;
  for (WorldId n : missing) {
    const MessageKey key{static_cast<int>(kind), s_.step, n};
    s_.inbox.emplace(key, empty_message(kind, n, me(), s_.step));
    bets_in_inbox_.insert(key);
    ++bets_;
  }
  return true;
}

// True if this step is fewer than `anticipation` steps past GVT; else the
// world asks to be woken when it is.
bool Speculation::within_anticipation() {
  const std::int64_t needed = s_.step - c_.safety.anticipation + 1;
  return !c_.safety.horizon->wake_at(me(), needed);
}

// A neighbour's message the step took from the inbox: kept (a merge: noted).
void Speculation::used(const MessageKey& key, const Message& m) {
  const auto& [kind, step, from] = key;
  if (is_merge_message(m)) {
    merge_steps_.insert(step);
    return;  // a merge: the rollback of every world takes care of it
  }
  Used u;
  if (bets_in_inbox_.erase(key)) {
    u.bet = true;
    u.confirmed = false;
    u.digest = message_digest(m);
    ++unconfirmed_[step];
  } else {
    u.message = m;  // its digest is taken only if its sender voids it
  }
  used_.insert_or_assign(UsedKey{step, kind, from}, std::move(u));
}

// A Ghosts, Migrants or empty Glue message for a step this run used one
// of: confirm it or roll back. True if the message has been taken care of
// (else it goes to the inbox).
bool Speculation::compare_with_used(Message& m) {
  auto it = used_.find(UsedKey{m.step, static_cast<int>(m.kind()), m.from});
  if (it == used_.end()) return false;
  Used& u = it->second;
  if (u.confirmed)
    throw std::logic_error("world " + std::to_string(me()) + " got " + describe(m) +
                           " again, without a rollback notice");
  if (message_digest(m) == u.digest) {
    u.confirmed = true;
    u.bet = false;  // met
    u.message = std::move(m);
    const std::int64_t s = std::get<0>(it->first);
    if (--unconfirmed_[s] == 0) unconfirmed_.erase(s);
    report_mark();
    return true;
  }
  if (u.bet) {
    ++bets_lost_;
    lost_bets_.insert(MessageKey{static_cast<int>(m.kind()), m.step, m.from});
  }
  SPEC_TRACE("w%d at %lld: %s differs from the one used (bet %d)\n", me(), (long long)s_.step,
             describe(m).c_str(), u.bet);
  const std::int64_t step = m.step;
  roll_back(step);
  return screen(m);  // then to the inbox (dropped if a rollback of every world voided it)
}

// Neighbour `from` rolled back to `step` on its own (it had no merge
// messages from that step on): its messages of steps >= step sent before
// this are void. Drops those not used yet; the ones used await their
// re-send, which is compared with them.
void Speculation::take_notice(WorldId from, std::int64_t step) {
  SPEC_TRACE("w%d at %lld: notice from %d: rolled back to %lld\n", me(), (long long)s_.step, from,
             (long long)step);
  // Fuzzing: other worlds run on while this one takes the notice in (the
  // horizon must not move past the notice's step meanwhile: screen()).
  if (c_.safety.fuzz) fuzz_pause(*c_.safety.fuzz);
  for (auto it = s_.inbox.begin(); it != s_.inbox.end();) {
    const auto& [kind, s, f] = it->first;
    if (f == from && s >= step) {
      bets_in_inbox_.erase(it->first);
      it = s_.inbox.erase(it);
    } else {
      ++it;
    }
  }
  for (auto it = s_.fragments.lower_bound(step); it != s_.fragments.end(); ++it)
    std::erase_if(it->second, [&](const Message& m) { return m.from == from; });
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
void Speculation::roll_back(std::int64_t step) {
  if (step < c_.safety.horizon->gvt())
    throw std::logic_error("world " + std::to_string(me()) + ": rollback to step " + std::to_string(step) +
                           ", below the commit horizon " + std::to_string(c_.safety.horizon->gvt()));
  const std::int64_t back = checkpoint_at_or_before(step);
  const bool merged = merge_steps_.lower_bound(back) != merge_steps_.end();
  if (merged || c_.safety.recompute) {
    SPEC_TRACE("w%d at %lld: posts a rollback of every world to %lld\n", me(), (long long)s_.step,
               (long long)back);
    c_.safety.board->post(back, step, me());
    catch_up();
    return;
  }
  restore(back, step, true);
  for (WorldId n : c_.neighbours) {
    if (!c_.safety.horizon->try_pin(step))
      throw std::logic_error("world " + std::to_string(me()) + ": rolled back below the commit horizon");
    Message notice;
    notice.payload = Control{Control::Type::Notice, ++notices_sent_[n], back, step};
    c_.send(n, std::move(notice));
  }
}

// Checkpoints are kept at internal steps that are multiples of
// checkpoint_every_ (the same steps in every world), and at the first step.
std::int64_t Speculation::checkpoint_at_or_before(std::int64_t step) const {
  auto it = c_.kept.states().upper_bound(step);
  if (it == c_.kept.states().begin())
    throw std::logic_error("world " + std::to_string(me()) + ": no state kept at or before step " +
                           std::to_string(step));
  return std::prev(it)->first;
}

// Rollbacks of every world this world has not taken in yet: restore each
// step it has passed, drop every message their epochs voided.
void Speculation::catch_up() {
  for (const RollbackBoard::Entry& e : c_.safety.board->since(seen_epoch_)) {
    // Rollback and Propagate: the world keeps its old run, which its re-run
    // rejoins if its own state and messages turn out unchanged.
    if (s_.step > e.step || (s_.step == e.step && s_.phase != StepPhase::Predict)) {
      restore(e.step, e.pinned, !c_.safety.recompute);
      // An input at a step readers hold may reach below what was committed:
      // the re-run reports its steps again (RunControl::rolled_back).
      committed_reported_ = std::min(committed_reported_, e.step / c_.substeps);
    }
    seen_epoch_ = e.epoch;
    auto void_message = [&](const Message& m) { return m.epoch < e.epoch && m.step >= e.step; };
    for (auto it = s_.inbox.begin(); it != s_.inbox.end();) {
      if (!bets_in_inbox_.count(it->first) && void_message(it->second)) {
        it = s_.inbox.erase(it);
      } else {
        ++it;
      }
    }
    for (auto& [s, list] : s_.fragments) std::erase_if(list, void_message);
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
void Speculation::await_resend(std::int64_t step, Used& u) {
  u.confirmed = false;
  u.digest = message_digest(*u.message);
  u.message.reset();
  ++unconfirmed_[step];
}

// Low-water mark: the clock, or the oldest step of a message used that may
// still change.
void Speculation::report_mark() {
  std::int64_t mark = s_.step;
  if (!unconfirmed_.empty()) mark = std::min(mark, unconfirmed_.begin()->first);
  c_.safety.horizon->report(me(), mark);
}

// Nothing below GVT can change: states, uses and validation reports of
// those steps are final.
void Speculation::trim_below(std::int64_t gvt) {
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
