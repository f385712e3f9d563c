// One world's process applying what its speculation decided (speculation.h,
// world_process.h): the inbox, the merge queue, the phase and the world
// change here and in the stages, nowhere else.
#include <algorithm>

#include "execution/transport_bytes.h"
#include "step/world_process.h"

namespace soda {

// What speculation decided (speculation.h, invariant 1): the only place,
// besides the stages, where the step's inbox, merge queue, phase and world
// change.
void PartitionedWorld::Process::apply(Verdict v) {
  if (v.empty()) return;
  for (InboxEdit& e : v.inbox) edit_inbox(e);
  if (v.restart) s_.begin_again(safety_.rebuild(*v.restart->state, v.restart->step), v.restart->step);
  if (v.republish_from >= 0) {
    output_.buffer->invalidate_from(v.republish_from);
    s_.next_publish = std::min(s_.next_publish, v.republish_from);
  }
  for (auto& [to, m] : v.send) send(to, std::move(m));
  for (Message& m : v.resend) resend(std::move(m));
  if (!v.backlog.empty()) {
    for (TransformEntry<btScalar>& e : v.backlog) s_.backlog.push_back(std::move(e));
    s_.phase = StepPhase::Publish;  // a rejoin took steps back: their entries first
  }
  if (v.replay) s_.world->set_replay(*v.replay);
}

void PartitionedWorld::Process::edit_inbox(InboxEdit& e) {
  switch (e.kind) {
    case InboxEdit::Kind::Put: s_.inbox.emplace(e.key, std::move(e.message)); break;  // one there stays
    case InboxEdit::Kind::Erase: s_.inbox.erase(e.key); break;
    case InboxEdit::Kind::DropFrom:
      std::erase_if(s_.inbox, [&](const auto& in) {
        return std::get<2>(in.first) == e.from && std::get<1>(in.first) >= e.step;
      });
      for (auto it = s_.fragments.lower_bound(e.step); it != s_.fragments.end(); ++it)
        std::erase_if(it->second, [&](const Message& m) { return m.from == e.from; });
      break;
    case InboxEdit::Kind::DropVoid: {
      auto void_message = [&](const Message& m) { return m.epoch < e.epoch && m.step >= e.step; };
      std::erase_if(s_.inbox, [&](const auto& in) { return !e.keep.count(in.first) && void_message(in.second); });
      for (auto& [step, list] : s_.fragments) std::erase_if(list, void_message);
      break;
    }
  }
}

// A message sent again exactly as it was (a rejoin: the old run's).
void PartitionedWorld::Process::resend(Message m) {
  ++sums_.messages_sent;
  const std::uint64_t bytes0 = thread_bytes_sent();
  const WorldId to = m.to;
  const MessageKind kind = m.kind();
  transport_.send(to, std::move(m));
  clock_.sent(to, kind, thread_bytes_sent() - bytes0);
}

}  // namespace soda
