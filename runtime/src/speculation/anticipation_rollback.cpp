// One world's speculation, going back (anticipation.h): restoring a kept
// state, rejoining the run a re-run left, replaying what a re-run step
// repeats unchanged — each a decision in the verdict of the hook running.
#include <algorithm>
#include <stdexcept>
#include <string>

#include "soda/runtime/message_codec.h"
#include "speculation/anticipation.h"

namespace soda {
namespace {

// The raw states of a part snapshot's bodies (what owned_states() gives for
// the world the snapshot was taken of).
std::vector<BodyState> body_states_of(const WorldSnapshot& part) {
  std::vector<BodyState> out(part.bodies.size());
  for (std::size_t i = 0; i < part.bodies.size(); ++i) {
    const BodyDynamicState& d = part.bodies[i].state;
    BodyState& s = out[i];
    s.id = part.bodies[i].description.id;
    std::copy(std::begin(d.basis), std::end(d.basis), s.basis);
    std::copy(std::begin(d.origin), std::end(d.origin), s.origin);
    std::copy(std::begin(d.linear_velocity), std::end(d.linear_velocity), s.linear_velocity);
    std::copy(std::begin(d.angular_velocity), std::end(d.angular_velocity), s.angular_velocity);
    s.activation_state = d.activation_state;
  }
  return out;
}

}  // namespace

// Restores this world's kept state at `step` (at or below its clock) and
// puts the messages it used from `step` on back in the inbox for the re-run.
// `changed_step` (>= step, >= GVT): the step whose message or input changed;
// states before it come out of the re-run unchanged. `keep_old_run`: a
// rollback of its own; what the run had done past `step` is kept for
// try_rejoin.
void Anticipation::restore(std::int64_t step, std::int64_t changed_step, bool keep_old_run) {
  StageClock::Scope stage(c_.clock, Stage::Rollback);
  c_.clock.count(Stage::Rollback, 1);
  const std::string who = "world " + std::to_string(me());
  const std::int64_t at = at_step();
  const StepPhase phase = at_phase();
  if (step > at) throw std::logic_error(who + ": rollback to step " + std::to_string(step) + " ahead of its clock");
  auto kept = c_.kept.states().find(step);
  if (kept == c_.kept.states().end())
    throw std::logic_error(who + ": rollback to step " + std::to_string(step) + ", which it no longer keeps");
  SPEC_TRACE("w%d at %lld: restores %lld (phase %d)\n", me(), (long long)at, (long long)step,
             static_cast<int>(phase));
  ++rollbacks_;
  steps_rolled_back_ += static_cast<std::uint64_t>(at - step);
  // The step in progress is a re-run once it has solved something (the
  // islands are solved after the ghosts arrive); a world waiting for ghosts
  // had only predicted, one publishing had ended the step.
  const bool solved =
      phase == StepPhase::AwaitGlue || phase == StepPhase::Merging || phase == StepPhase::AwaitMigrants;
  rerun_until_ = std::max(rerun_until_, solved ? at + 1 : at);
  partial_step_.reset();
  if (solved && keep_old_run) {
    PartialStep& p = partial_step_.emplace();
    p.step = at;  // solved: no restart decided before in this hook, s_.world is the step's
    p.integrated = phase == StepPhase::AwaitMigrants;
    if (p.integrated) {
      p.islands = s_.world->local_islands();
      s_.world->part_snapshot(p.state);
    } else if (!s_.world->solved_state(p.islands, p.state)) {
      partial_step_.reset();
    }
  }
  restored_to_ = step;
  out().restart = Verdict::Restart{step, &kept->second};
  if (c_.output.buffer) {
    // Entries of boundaries after the changed step are void: republished
    // with a new revision by the re-run. Earlier ones come out of the re-run
    // unchanged and stay (the re-run skips them). The changed step is at or
    // above the GVT read now, but GVT may have gone down since this world
    // set its commit step (a rollback of every world lowers the marks to a
    // checkpoint below the pinned step, and the re-run of the steps between
    // bets again: a bet lost there changes a step below the commit step).
    // Committed steps were computed from confirmed messages only; the re-run
    // repeats them bit for bit, so they stay too.
    const std::int64_t first = std::max(changed_step / c_.substeps + 1, c_.output.buffer->commit_step() + 1);
    Verdict& v = out();
    v.republish_from = v.republish_from < 0 ? first : std::min(v.republish_from, first);
    last_published_ = std::min(last_published_, first - 1);
  }
  if (old_run_) drop_old_run();  // rolled back again (or for every world): the re-run leaves the old run
  if (keep_old_run && std::next(kept) != c_.kept.states().end()) {
    OldRun& old = old_run_.emplace();
    old.changed_step = changed_step;
    while (std::next(kept) != c_.kept.states().end()) old.kept.insert(c_.kept.states().extract(std::next(kept)));
    for (auto it = used_.lower_bound(UsedKey{step, 0, kNoWorld}); it != used_.end(); ++it)
      old.used.emplace(it->first, it->second);
    while (sent_log_.lower_bound(step) != sent_log_.end()) old.sent.insert(sent_log_.extract(sent_log_.lower_bound(step)));
    old.merge_steps.insert(merge_steps_.lower_bound(step), merge_steps_.end());
    while (island_log_.lower_bound(step) != island_log_.end())
      old.islands.insert(island_log_.extract(island_log_.lower_bound(step)));
    while (reports_.upper_bound(step) != reports_.end()) old.reports.insert(reports_.extract(reports_.upper_bound(step)));
  }
  c_.kept.drop(std::next(kept), c_.kept.states().end());
  reports_.erase(reports_.upper_bound(step), reports_.end());
  sent_log_.erase(sent_log_.lower_bound(step), sent_log_.end());
  island_log_.erase(island_log_.lower_bound(step), island_log_.end());
  merge_steps_.erase(merge_steps_.lower_bound(step), merge_steps_.end());
  for (const MessageKey& k : bets_in_inbox_) out().inbox.push_back(InboxEdit{.kind = InboxEdit::Kind::Erase, .key = k});
  bets_in_inbox_.clear();
  for (auto it = used_.lower_bound(UsedKey{step, 0, kNoWorld}); it != used_.end(); it = used_.erase(it)) {
    const auto [s, kind, from] = it->first;
    Used& u = it->second;
    if (!u.confirmed) {
      if (--unconfirmed_[s] == 0) unconfirmed_.erase(s);
    } else if (u.message) {
      out().inbox.push_back(
          InboxEdit{.kind = InboxEdit::Kind::Put, .key = MessageKey{kind, s, from}, .message = std::move(*u.message)});
    }
  }
  report_mark();
}

// After a re-run step: if the state equals the old run's at this step, past
// the message that changed, and every message the old run used from here to
// its newest kept state is the one at hand (in the inbox, or voided since by
// its sender and so awaiting its re-send), the old run's steps from here on
// are what the re-run would compute. Take them back: its uses, its kept
// states and reports, its sent messages (re-sent: the rollback's Notice
// voided them), and the world rebuilt at its newest kept state.
void Anticipation::try_rejoin() {
  StageClock::Scope stage(c_.clock, Stage::Rollback);
  const std::int64_t j = old_run_->kept.rbegin()->first;
  if (s_.step >= j) {
    drop_old_run();  // the re-run has caught up: nothing left to take back
    return;
  }
  std::vector<std::pair<std::int64_t, const WorldSnapshot*>> entries;  // (scene step, state)
  if (may_rejoin(j, entries)) rejoin(j, entries);
}

// The rejoin's conditions (above); `entries`: under a Simulation, the old
// run's entries of these steps were dropped from the buffer (restore): they
// are republished from the kept states, so each scene step not yet published
// needs one. Drops the old run if one of its messages changed.
bool Anticipation::may_rejoin(std::int64_t j,
                              std::vector<std::pair<std::int64_t, const WorldSnapshot*>>& entries) {
  OldRun& old = *old_run_;
  const std::int64_t s = s_.step;
  if (s <= old.changed_step) return false;
  auto old_state = old.kept.find(s);
  auto new_state = c_.kept.states().find(s);
  if (old_state == old.kept.end() || new_state == c_.kept.states().end()) return false;
  if (!same_bits(old_state->second, new_state->second)) return false;
  const auto in_range = [&](std::int64_t step) { return step >= s && step < j; };
  std::size_t at_hand = 0;
  for (const auto& [key, m] : s_.inbox) at_hand += in_range(std::get<1>(key));
  for (const auto& [step, list] : s_.fragments)
    if (in_range(step) && !list.empty()) return false;  // a merge the old run did not have
  // Merge messages are not kept for comparison: steps of the old run that
  // merged islands cannot be taken back.
  auto merged = old.merge_steps.lower_bound(s);
  if (merged != old.merge_steps.end() && *merged < j) return false;
  const UsedKey from{s, 0, kNoWorld}, to{j, 0, kNoWorld};
  std::size_t matched = 0;
  for (auto it = old.used.lower_bound(from); it != old.used.end() && it->first < to; ++it) {
    const auto& [step, kind, sender] = it->first;
    auto in = s_.inbox.find(MessageKey{kind, step, sender});
    if (in == s_.inbox.end()) continue;
    ++matched;
    const Used& u = it->second;
    if (message_digest(in->second) != (u.message ? message_digest(*u.message) : u.digest)) {
      drop_old_run();  // a message of the old run's steps changed: re-run them
      return false;
    }
  }
  if (matched != at_hand) return false;  // messages the old run did not use: re-run
  if (!c_.output.buffer) return true;
  for (std::int64_t b = std::max(s_.next_publish, (s + c_.substeps - 1) / c_.substeps); b * c_.substeps < j; ++b) {
    const std::int64_t at = b * c_.substeps;
    const WorldSnapshot* state = nullptr;
    if (at == s) state = &new_state->second;
    if (auto it = old.kept.find(at); at != s && it != old.kept.end()) state = &it->second;
    if (!state) return false;  // not kept (checkpoint_every > 1): re-run
    entries.emplace_back(b, state);
  }
  return true;
}

// Takes the old run's steps [s_.step, j) back (may_rejoin said so).
void Anticipation::rejoin(std::int64_t j,
                          const std::vector<std::pair<std::int64_t, const WorldSnapshot*>>& entries) {
  OldRun& old = *old_run_;
  const std::int64_t s = s_.step;
  const UsedKey from{s, 0, kNoWorld}, to{j, 0, kNoWorld};
  SPEC_TRACE("w%d at %lld: re-run rejoins the old run at %lld, takes back %lld steps\n", me(),
             (long long)s, (long long)s, (long long)(j - s));
  Verdict& v = out();
  for (auto it = old.used.lower_bound(from); it != old.used.end() && it->first < to; ++it) {
    const auto& [step, kind, sender] = it->first;
    Used u = std::move(it->second);
    auto in = s_.inbox.find(MessageKey{kind, step, sender});
    if (in != s_.inbox.end()) {
      u.confirmed = true;  // equal to the one used (checked above)
      u.bet = false;
      u.message = in->second;
      v.inbox.push_back(InboxEdit{.kind = InboxEdit::Kind::Erase, .key = in->first});
    } else if (u.message) {
      await_resend(step, u);  // voided by its sender since
    } else {
      ++unconfirmed_[step];  // a bet not yet met, or a re-send still awaited
    }
    used_.insert_or_assign(it->first, std::move(u));
  }
  for (auto it = old.sent.lower_bound(s); it != old.sent.end() && it->first < j; ++it) {
    for (const Message& m : it->second) {
      v.resend.push_back(m);
      v.resend.back().epoch = seen_epoch_;
    }
    sent_log_.insert_or_assign(it->first, std::move(it->second));
  }
  for (auto it = old.islands.lower_bound(s); it != old.islands.end() && it->first < j;) {
    auto next = std::next(it);
    island_log_.insert_or_assign(it->first, std::move(it->second));
    it = next;
  }
  for (auto it = old.kept.upper_bound(s); it != old.kept.end();) {
    auto next = std::next(it);
    c_.kept.states().insert(old.kept.extract(it));
    it = next;
  }
  for (auto it = old.reports.upper_bound(s); it != old.reports.end() && it->first <= j; ++it)
    if (it->first > reported_through_) reports_.insert_or_assign(it->first, std::move(it->second));
  for (const auto& [scene_step, state] : entries) {
    v.backlog.push_back(transform_entry(scene_step, c_.output.dt, body_states_of(*state)));
    if (c_.output.contacts) {
      // The part as kept holds what the live world would have reported from.
      std::vector<BodyId> owned;
      owned.reserve(state->bodies.size());
      for (const BodySnapshot& b : state->bodies) owned.push_back(b.description.id);
      v.backlog.back().contacts = reported_contacts(*s_.world, state->manifolds, owned);
    }
  }
  steps_rejoined_ += static_cast<std::uint64_t>(j - s);
  old_run_.reset();
  partial_step_.reset();
  v.restart = Verdict::Restart{j, &c_.kept.states().at(j)};
  c_.kept.noted();
  report_mark();
}

// Before a re-run step's predict(): the step replays the islands of the old
// run's step that come out unchanged (TerritoryWorld::set_replay) if the old
// run's state at both ends of the step and its islands are at hand (states
// are kept every checkpoint_every steps: 1 replays every step; the step a
// rollback interrupted has its own record, partial_step_). At the step
// restored to, the state kept is the old run's: it was restored from it.
void Anticipation::arm_replay() {
  const std::int64_t r = s_.step;
  const LocalIslands* islands = nullptr;
  const WorldSnapshot* after = nullptr;
  bool mid_step = false;
  if (partial_step_ && partial_step_->step == r) {
    islands = &partial_step_->islands;
    after = &partial_step_->state;
    mid_step = !partial_step_->integrated;
  } else if (old_run_) {
    auto i = old_run_->islands.find(r);
    auto a = old_run_->kept.find(r + 1);
    if (i == old_run_->islands.end() || a == old_run_->kept.end()) return;
    islands = &i->second;
    after = &a->second;
  } else {
    return;
  }
  const WorldSnapshot* before = nullptr;
  if (r == restored_to_) {
    if (auto own = c_.kept.states().find(r); own != c_.kept.states().end()) before = &own->second;
  } else if (old_run_) {
    if (auto it = old_run_->kept.find(r); it != old_run_->kept.end()) before = &it->second;
  }
  if (!before) return;
  out().replay = StepReplay{before, after, islands, mid_step, c_.safety.verify_replay};
}

void Anticipation::drop_old_run() {
  for (auto& [step, state] : old_run_->kept) c_.kept.recycle(std::move(state));
  old_run_.reset();
}

}  // namespace soda
