// One world's speculation (world_process.h, docs/rollback.md): bets on empty
// neighbour messages, the messages it used, rollback notices, rejoining the
// run a re-run left, and its low-water mark in the commit horizon.
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
#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "soda/loadbalance/thread_clock.h"
#include "soda/runtime/message_codec.h"
#include "soda/worlds/world_snapshot.h"
#include "world_process.h"

namespace soda {
namespace {

const bool kTrace = std::getenv("SODA_SPEC_TRACE") != nullptr;
#define SPEC_TRACE(...)                    \
  do {                                     \
    if (kTrace) std::fprintf(stderr, __VA_ARGS__); \
  } while (0)

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


// The neighbours whose `kind` of this step is missing: bet that it is empty,
// if every one of them is a neighbour this world sent no ghosts to (and, for
// Migrants, got no ghosts from), no bet on it was lost at this step, the
// newest ghosts that arrived from it were empty unless bets are eager (a
// border that has just become busy stays busy: betting on each following
// step lost one bet and re-ran the world each time), and the step is within
// the anticipation.
bool PartitionedWorld::Process::place_bets(MessageKind kind) {
  std::vector<WorldId> missing;
  for (WorldId n : neighbours_)
    if (!inbox_.count(Key{static_cast<int>(kind), step_, n})) missing.push_back(n);
  for (WorldId n : missing) {
    if (world_->sends_ghosts_to(n)) return false;
    if (kind == MessageKind::Migrants && world_->received_ghosts_from(n)) return false;
    if (lost_bets_.count(Key{static_cast<int>(kind), step_, n})) return false;
    auto newest = newest_ghosts_.find(n);
    if (!safety_.eager_bets && newest != newest_ghosts_.end() && newest->second.second) return false;
  }
  if (!within_anticipation()) return false;
  for (WorldId n : missing) {
    const Key key{static_cast<int>(kind), step_, n};
    inbox_.emplace(key, empty_message(kind, n, world_->id(), step_));
    bets_in_inbox_.insert(key);
    ++bets_;
  }
  return true;
}

// True if this step is fewer than `anticipation` steps past GVT; else the
// world asks to be woken when it is.
bool PartitionedWorld::Process::within_anticipation() {
  const std::int64_t needed = step_ - safety_.anticipation + 1;
  return !safety_.horizon->wake_at(world_->id(), needed);
}

void PartitionedWorld::Process::record_used(const Key& key, const Message& m) {
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
// of: confirm it or roll back. True if the message has been taken care of.
bool PartitionedWorld::Process::compare_with_used(Message& m) {
  auto it = used_.find(UsedKey{m.step, static_cast<int>(m.kind()), m.from});
  if (it == used_.end()) return false;
  Used& u = it->second;
  if (u.confirmed)
    throw std::logic_error("world " + std::to_string(world_->id()) + " got " + describe(m) +
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
    lost_bets_.insert(Key{static_cast<int>(m.kind()), m.step, m.from});
  }
  SPEC_TRACE("w%d at %lld: %s differs from the one used (bet %d)\n", world_->id(), (long long)step_,
             describe(m).c_str(), u.bet);
  const std::int64_t step = m.step;
  roll_back(step);
  deliver(std::move(m));  // to the inbox (dropped if a rollback of every world voided it)
  return true;
}

// Neighbour `from` rolled back to `step` on its own (it had no merge
// messages from that step on): its messages of steps >= step sent before
// this are void. Drops those not used yet; the ones used await their
// re-send, which is compared with them.
void PartitionedWorld::Process::take_notice(WorldId from, std::int64_t step) {
  SPEC_TRACE("w%d at %lld: notice from %d: rolled back to %lld\n", world_->id(), (long long)step_, from,
             (long long)step);
  // Fuzzing: other worlds run on while this one takes the notice in (the
  // horizon must not move past the notice's step meanwhile: deliver()).
  if (safety_.fuzz) fuzz_pause(*safety_.fuzz);
  for (auto it = inbox_.begin(); it != inbox_.end();) {
    const auto& [kind, s, f] = it->first;
    if (f == from && s >= step) {
      bets_in_inbox_.erase(it->first);
      it = inbox_.erase(it);
    } else {
      ++it;
    }
  }
  for (auto it = fragments_.lower_bound(step); it != fragments_.end(); ++it)
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
void PartitionedWorld::Process::roll_back(std::int64_t step) {
  if (step < safety_.horizon->gvt())
    throw std::logic_error("world " + std::to_string(world_->id()) + ": rollback to step " + std::to_string(step) +
                           ", below the commit horizon " + std::to_string(safety_.horizon->gvt()));
  const std::int64_t back = checkpoint_at_or_before(step);
  const bool merged = merge_steps_.lower_bound(back) != merge_steps_.end();
  if (merged || safety_.recompute) {
    SPEC_TRACE("w%d at %lld: posts a rollback of every world to %lld\n", world_->id(), (long long)step_,
               (long long)back);
    safety_.board->post(back, step, world_->id());
    catch_up();
    return;
  }
  restore(back, step, true);
  for (WorldId n : neighbours_) {
    if (!safety_.horizon->try_pin(step))
      throw std::logic_error("world " + std::to_string(world_->id()) + ": rolled back below the commit horizon");
    Message notice;
    notice.payload = Control{Control::Type::Notice, ++notices_sent_[n], back, step};
    send(n, std::move(notice));
  }
}

// Checkpoints are kept at internal steps that are multiples of
// checkpoint_every_ (the same steps in every world), and at the first step.
std::int64_t PartitionedWorld::Process::checkpoint_at_or_before(std::int64_t step) const {
  auto it = kept_states_.upper_bound(step);
  if (it == kept_states_.begin())
    throw std::logic_error("world " + std::to_string(world_->id()) + ": no state kept at or before step " +
                           std::to_string(step));
  return std::prev(it)->first;
}

// Rollbacks of every world this world has not taken in yet: restore each
// step it has passed, drop every message their epochs voided.
void PartitionedWorld::Process::catch_up() {
  for (const RollbackBoard::Entry& e : safety_.board->since(seen_epoch_)) {
    // Rollback and Propagate: the world keeps its old run, which its re-run
    // rejoins if its own state and messages turn out unchanged.
    if (step_ > e.step || (step_ == e.step && phase_ != Phase::Predict))
      restore(e.step, e.pinned, !safety_.recompute);
    seen_epoch_ = e.epoch;
    auto void_message = [&](const Message& m) { return m.epoch < e.epoch && m.step >= e.step; };
    for (auto it = inbox_.begin(); it != inbox_.end();) {
      if (!bets_in_inbox_.count(it->first) && void_message(it->second)) {
        it = inbox_.erase(it);
      } else {
        ++it;
      }
    }
    for (auto& [s, list] : fragments_) std::erase_if(list, void_message);
    for (auto it = used_.lower_bound(UsedKey{e.step, 0, kNoWorld}); it != used_.end(); ++it) {
      Used& u = it->second;  // used at a step this world had not passed: void, awaiting the re-send
      if (u.confirmed && u.message && void_message(*u.message)) await_resend(std::get<0>(it->first), u);
    }
    report_mark();  // before the pin goes (as for a Notice: deliver)
    safety_.horizon->unpin(e.pinned);
  }
  report_mark();
}

// Restores this world's kept state at `step` (at or below its clock) and
// puts the messages it used from `step` on back in the inbox for the re-run.
// `changed_step` (>= step, >= GVT): the step whose message or input changed;
// states before it come out of the re-run unchanged. `keep_old_run`: a
// rollback of its own; what the run had done past `step` is kept for
// try_rejoin.
void PartitionedWorld::Process::restore(std::int64_t step, std::int64_t changed_step, bool keep_old_run) {
  const std::int64_t cpu0 = thread_cpu_ns();
  const std::string who = "world " + std::to_string(world_->id());
  if (step > step_) throw std::logic_error(who + ": rollback to step " + std::to_string(step) + " ahead of its clock");
  auto kept = kept_states_.find(step);
  if (kept == kept_states_.end())
    throw std::logic_error(who + ": rollback to step " + std::to_string(step) + ", which it no longer keeps");
  SPEC_TRACE("w%d at %lld: restores %lld (phase %d)\n", world_->id(), (long long)step_, (long long)step,
             static_cast<int>(phase_));
  ++rollbacks_;
  steps_rolled_back_ += static_cast<std::uint64_t>(step_ - step);
  // The step in progress is a re-run once it has solved something (the
  // islands are solved after the ghosts arrive); a world waiting for ghosts
  // had only predicted, one publishing had ended the step.
  const bool solved = phase_ == Phase::AwaitGlue || phase_ == Phase::Merging || phase_ == Phase::AwaitMigrants;
  rerun_until_ = std::max(rerun_until_, solved ? step_ + 1 : step_);
  partial_step_.reset();
  if (solved && keep_old_run) {
    PartialStep& p = partial_step_.emplace();
    p.step = step_;
    p.integrated = phase_ == Phase::AwaitMigrants;
    if (p.integrated) {
      p.islands = world_->local_islands();
      world_->part_snapshot(p.state);
    } else if (!world_->solved_state(p.islands, p.state)) {
      partial_step_.reset();
    }
  }
  restored_to_ = step;
  world_ = &safety_.rebuild(kept->second, step);
  step_ = step;
  phase_ = Phase::Predict;
  merger_ = IslandMerger{};
  islands_.clear();
  early_gathers_.clear();
  if (output_.buffer) {
    // Entries of boundaries after the changed step are void: republished
    // with a new revision by the re-run. Earlier ones come out of the re-run
    // unchanged and stay (the re-run skips them); the changed step is at or
    // above GVT, and the commit step below it, so none is committed.
    pending_.reset();
    backlog_.clear();
    publish_current_ = false;
    room_wait_since_ns_ = 0;
    const std::int64_t first = changed_step / substeps_ + 1;
    output_.buffer->invalidate_from(first);
    next_publish_ = std::min(next_publish_, first);
    last_published_ = std::min(last_published_, first - 1);
  }
  if (old_run_) drop_old_run();  // rolled back again (or for every world): the re-run leaves the old run
  if (keep_old_run && std::next(kept) != kept_states_.end()) {
    OldRun& old = old_run_.emplace();
    old.changed_step = changed_step;
    while (std::next(kept) != kept_states_.end()) old.kept.insert(kept_states_.extract(std::next(kept)));
    for (auto it = used_.lower_bound(UsedKey{step, 0, kNoWorld}); it != used_.end(); ++it)
      old.used.emplace(it->first, it->second);
    while (sent_log_.lower_bound(step) != sent_log_.end()) old.sent.insert(sent_log_.extract(sent_log_.lower_bound(step)));
    old.merge_steps.insert(merge_steps_.lower_bound(step), merge_steps_.end());
    while (island_log_.lower_bound(step) != island_log_.end())
      old.islands.insert(island_log_.extract(island_log_.lower_bound(step)));
    while (reports_.upper_bound(step) != reports_.end()) old.reports.insert(reports_.extract(reports_.upper_bound(step)));
  }
  for (auto it = std::next(kept); it != kept_states_.end(); it = kept_states_.erase(it)) recycle(std::move(it->second));
  reports_.erase(reports_.upper_bound(step), reports_.end());
  sent_log_.erase(sent_log_.lower_bound(step), sent_log_.end());
  island_log_.erase(island_log_.lower_bound(step), island_log_.end());
  merge_steps_.erase(merge_steps_.lower_bound(step), merge_steps_.end());
  for (const Key& k : bets_in_inbox_) inbox_.erase(k);
  bets_in_inbox_.clear();
  for (auto it = used_.lower_bound(UsedKey{step, 0, kNoWorld}); it != used_.end(); it = used_.erase(it)) {
    const auto [s, kind, from] = it->first;
    Used& u = it->second;
    if (!u.confirmed) {
      if (--unconfirmed_[s] == 0) unconfirmed_.erase(s);
    } else if (u.message) {
      inbox_.emplace(Key{kind, s, from}, std::move(*u.message));
    }
  }
  report_mark();
  // Restores run outside advance()'s CPU window (on delivery, or before the
  // stages): count them in the step in progress too, not only here.
  const std::int64_t ns = thread_cpu_ns() - cpu0;
  rollback_cpu_ns_ += ns;
  step_cpu_ns_ += ns;
  restore_ns_in_step_ += ns;
}

// After a re-run step: if the state equals the old run's at this step, past
// the message that changed, and every message the old run used from here to
// its newest kept state is the one at hand (in the inbox, or voided since by
// its sender and so awaiting its re-send), the old run's steps from here on
// are what the re-run would compute. Take them back: its uses, its kept
// states and reports, its sent messages (re-sent: the rollback's Notice
// voided them), and the world rebuilt at its newest kept state.
void PartitionedWorld::Process::try_rejoin() {
  OldRun& old = *old_run_;
  const std::int64_t s = step_;
  const std::int64_t j = old.kept.rbegin()->first;
  if (s >= j) {
    drop_old_run();  // the re-run has caught up: nothing left to take back
    return;
  }
  if (s <= old.changed_step) return;
  auto old_state = old.kept.find(s);
  auto new_state = kept_states_.find(s);
  if (old_state == old.kept.end() || new_state == kept_states_.end()) return;
  if (!same_bits(old_state->second, new_state->second)) return;

  const auto in_range = [&](std::int64_t step) { return step >= s && step < j; };
  std::size_t at_hand = 0;
  for (const auto& [key, m] : inbox_) at_hand += in_range(std::get<1>(key));
  for (const auto& [step, list] : fragments_)
    if (in_range(step) && !list.empty()) return;  // a merge the old run did not have
  // Merge messages are not kept for comparison: steps of the old run that
  // merged islands cannot be taken back.
  auto merged = old.merge_steps.lower_bound(s);
  if (merged != old.merge_steps.end() && *merged < j) return;
  const UsedKey from{s, 0, kNoWorld}, to{j, 0, kNoWorld};
  std::size_t matched = 0;
  for (auto it = old.used.lower_bound(from); it != old.used.end() && it->first < to; ++it) {
    const auto& [step, kind, sender] = it->first;
    auto in = inbox_.find(Key{kind, step, sender});
    if (in == inbox_.end()) continue;
    ++matched;
    const Used& u = it->second;
    if (message_digest(in->second) != (u.message ? message_digest(*u.message) : u.digest)) {
      drop_old_run();  // a message of the old run's steps changed: re-run them
      return;
    }
  }
  if (matched != at_hand) return;  // messages the old run did not use: re-run
  // Under a Simulation the old run's entries of these steps were dropped
  // from the buffer (restore): they are republished from the kept states,
  // so each scene step not yet published needs one.
  std::vector<std::pair<std::int64_t, const WorldSnapshot*>> entries;  // (scene step, state)
  if (output_.buffer) {
    for (std::int64_t b = std::max(next_publish_, (s + substeps_ - 1) / substeps_); b * substeps_ < j; ++b) {
      const std::int64_t at = b * substeps_;
      const WorldSnapshot* state = nullptr;
      if (at == s) state = &new_state->second;
      if (auto it = old.kept.find(at); at != s && it != old.kept.end()) state = &it->second;
      if (!state) return;  // not kept (checkpoint_every > 1): re-run
      entries.emplace_back(b, state);
    }
  }

  SPEC_TRACE("w%d at %lld: re-run rejoins the old run at %lld, takes back %lld steps\n", world_->id(),
             (long long)s, (long long)s, (long long)(j - s));
  for (auto it = old.used.lower_bound(from); it != old.used.end() && it->first < to; ++it) {
    const auto& [step, kind, sender] = it->first;
    Used u = std::move(it->second);
    auto in = inbox_.find(Key{kind, step, sender});
    if (in != inbox_.end()) {
      u.confirmed = true;  // equal to the one used (checked above)
      u.bet = false;
      u.message = std::move(in->second);
      inbox_.erase(in);
    } else if (u.message) {
      await_resend(step, u);  // voided by its sender since
    } else {
      ++unconfirmed_[step];  // a bet not yet met, or a re-send still awaited
    }
    used_.insert_or_assign(it->first, std::move(u));
  }
  for (auto it = old.sent.lower_bound(s); it != old.sent.end() && it->first < j; ++it) {
    for (const Message& m : it->second) {
      Message again = m;
      again.epoch = seen_epoch_;
      ++sums_.messages_sent;
      transport_.send(again.to, std::move(again));
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
    kept_states_.insert(old.kept.extract(it));
    it = next;
  }
  for (auto it = old.reports.upper_bound(s); it != old.reports.end() && it->first <= j; ++it)
    if (it->first > reported_through_) reports_.insert_or_assign(it->first, std::move(it->second));
  for (const auto& [scene_step, state] : entries) backlog_.push_back(entry_of(scene_step, body_states_of(*state)));
  steps_rejoined_ += static_cast<std::uint64_t>(j - s);
  old_run_.reset();
  partial_step_.reset();
  world_ = &safety_.rebuild(kept_states_.at(j), j);
  step_ = j;
  phase_ = Phase::Predict;
  kept_max_ = std::max(kept_max_, kept_states_.size());
  report_mark();
}

// Before a re-run step's predict(): the step replays the islands of the old
// run's step that come out unchanged (TerritoryWorld::set_replay) if the old
// run's state at both ends of the step and its islands are at hand (states
// are kept every checkpoint_every steps: 1 replays every step; the step a
// rollback interrupted has its own record, partial_step_). At the step
// restored to, the state kept is the old run's: it was restored from it.
void PartitionedWorld::Process::arm_replay() {
  const std::int64_t r = step_;
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
    if (auto own = kept_states_.find(r); own != kept_states_.end()) before = &own->second;
  } else if (old_run_) {
    if (auto it = old_run_->kept.find(r); it != old_run_->kept.end()) before = &it->second;
  }
  if (!before) return;
  world_->set_replay(StepReplay{before, after, islands, mid_step, safety_.verify_replay});
}

void PartitionedWorld::Process::drop_old_run() {
  for (auto& [step, state] : old_run_->kept) recycle(std::move(state));
  old_run_.reset();
}

// A kept state no longer needed: its storage is reused by a later one. Up
// to as many as were ever kept at once (GVT moves in jumps: a jump frees
// many states, which the next steps would otherwise allocate again: page
// faults were 3.8 % of a speculative run on alternating-load with a state
// every step); the memory held stays the high-water mark.
void PartitionedWorld::Process::recycle(WorldSnapshot&& state) {
  if (spare_states_.size() < std::max<std::size_t>(4, kept_max_)) spare_states_.push_back(std::move(state));
}

// A used message its sender voided (a Notice, a rollback of every world):
// kept as a digest, unconfirmed, until the re-send is compared with it.
void PartitionedWorld::Process::await_resend(std::int64_t step, Used& u) {
  u.confirmed = false;
  u.digest = message_digest(*u.message);
  u.message.reset();
  ++unconfirmed_[step];
}

// Low-water mark: the clock, or the oldest step of a message used that may
// still change.
void PartitionedWorld::Process::report_mark() {
  std::int64_t mark = step_;
  if (!unconfirmed_.empty()) mark = std::min(mark, unconfirmed_.begin()->first);
  safety_.horizon->report(world_->id(), mark);
}

// Nothing below GVT can change: states, uses and validation reports of
// those steps are final.
void PartitionedWorld::Process::trim_below(std::int64_t gvt) {
  // A rollback to a step at or above GVT restores the checkpoint at or
  // before it and re-runs from there with the messages used: keep both.
  const std::int64_t keep = checkpoint_at_or_before(gvt);
  for (auto it = kept_states_.begin(); it != kept_states_.end() && it->first < keep; it = kept_states_.erase(it))
    recycle(std::move(it->second));
  used_.erase(used_.begin(), used_.lower_bound(UsedKey{keep, 0, kNoWorld}));
  sent_log_.erase(sent_log_.begin(), sent_log_.lower_bound(keep));
  island_log_.erase(island_log_.begin(), island_log_.lower_bound(keep));
  merge_steps_.erase(merge_steps_.begin(), merge_steps_.lower_bound(keep));
  std::erase_if(lost_bets_, [keep](const Key& k) { return std::get<1>(k) < keep; });
  if (validator_) {
    auto end = reports_.upper_bound(gvt);
    for (auto it = reports_.begin(); it != end; ++it) {
      validator_->report(std::move(it->second));
      reported_through_ = it->first;
    }
    reports_.erase(reports_.begin(), end);
  }
}

}  // namespace soda
