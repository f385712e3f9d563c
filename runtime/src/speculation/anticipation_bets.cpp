// One world's speculation (anticipation.h): its bets on empty neighbour
// messages, the messages it used, and the comparison of a message with the
// one used at its step (a bet met or lost, a re-send equal or not).
#include <stdexcept>
#include <string>

#include "speculation/anticipation.h"
#include "soda/runtime/message_codec.h"

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

// The neighbours whose `kind` of this step is missing: bet that it is empty,
// if every one of them is a neighbour this world sent no ghosts to (and, for
// Migrants, got no ghosts from), no bet on it was lost at this step, the
// newest ghosts that arrived from it were empty unless bets are eager (a
// border that has just become busy stays busy: betting on each following
// step lost one bet and re-ran the world each time), and the step is within
// the anticipation.
Verdict Anticipation::bet(MessageKind kind) {
  Verdict v;
  Building building(*this, v);
  std::vector<WorldId> missing;
  for (WorldId n : c_.neighbours)
    if (!s_.inbox.count(message_key(kind, s_.step, n))) missing.push_back(n);
  for (WorldId n : missing) {
    if (s_.world->sends_ghosts_to(n)) return v;
    if (kind == MessageKind::Migrants && s_.world->received_ghosts_from(n)) return v;
    if (lost_bets_.count(message_key(kind, s_.step, n))) return v;
    auto newest = newest_ghosts_.find(n);
    if (!c_.safety.eager_bets && newest != newest_ghosts_.end() && newest->second.second) return v;
  }
  if (!within_anticipation()) return v;
  for (WorldId n : missing) {
    const MessageKey key{static_cast<int>(kind), s_.step, n};
    v.inbox.push_back(InboxEdit{.kind = InboxEdit::Kind::Put, .key = key, .message = empty_message(kind, n, me(), s_.step)});
    bets_in_inbox_.insert(key);
    ++bets_;
  }
  return v;
}

// True if this step is fewer than `anticipation` steps past GVT; else the
// world asks to be woken when it is.
bool Anticipation::within_anticipation() {
  const std::int64_t needed = s_.step - c_.safety.anticipation + 1;
  return !c_.safety.horizon->wake_at(me(), needed);
}

// A neighbour's message the step took from the inbox: kept (a merge: noted).
void Anticipation::used(const MessageKey& key, const Message& m) {
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

// A Ghosts, Migrants or Glue message for a step this run used one of (a
// Glue used is an empty one; the one sent again may hold entries): confirm
// it or roll back. True if the message has been taken care of
// (else it goes to the inbox).
bool Anticipation::compare_with_used(Message& m) {
  auto it = used_.find(UsedKey{m.step, static_cast<int>(m.kind()), m.from});
  if (it == used_.end()) return false;
  Used& u = it->second;
  if (u.confirmed)
    throw std::logic_error("world " + std::to_string(me()) + " got " + describe(m) +
                           " again, without a rollback notice");
  if (message_digest(m) == u.digest) {
    u.confirmed = true;
    u.bet = false;  // met
    u.message = std::move(m);  // dropped by the step: taken care of here
    const std::int64_t s = std::get<0>(it->first);
    if (--unconfirmed_[s] == 0) unconfirmed_.erase(s);
    report_mark();
    return true;
  }
  if (u.bet) {
    ++bets_lost_;
    lost_bets_.insert(MessageKey{static_cast<int>(m.kind()), m.step, m.from});
  }
  SPEC_TRACE("w%d at %lld: %s differs from the one used (bet %d)\n", me(), (long long)at_step(),
             describe(m).c_str(), u.bet);
  const std::int64_t step = m.step;
  roll_back(step);
  return screen_into(m);  // then to the inbox (dropped if a rollback of every world voided it)
}

}  // namespace soda
