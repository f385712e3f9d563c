#include "step/message_tally.h"

#include <algorithm>
#include <tuple>

namespace soda {
namespace {

std::size_t kind_index(MessageKind kind) { return static_cast<std::size_t>(kind) - 1; }

}  // namespace

MessageFlow& MessageTally::flow(WorldId to, MessageKind kind) {
  std::vector<MessageFlow>& flows = totals_.flows;
  const auto key = std::make_tuple(to, kind);
  auto it = std::lower_bound(flows.begin(), flows.end(), key,
                             [](const MessageFlow& f, const auto& k) { return std::make_tuple(f.to, f.kind) < k; });
  if (it == flows.end() || it->to != to || it->kind != kind) it = flows.insert(it, MessageFlow{.to = to, .kind = kind});
  return *it;
}

void MessageTally::sent(WorldId to, MessageKind kind, std::uint64_t bytes) {
  MessageFlow& f = flow(to, kind);
  ++f.messages;
  f.bytes += bytes;
  for (StepCount& c : step_)
    if (c.to == to && c.kind == kind) {
      ++c.messages;
      return;
    }
  step_.push_back(StepCount{to, kind, 1});
}

void MessageTally::island_depth(std::uint64_t depth) { step_depth_ = std::max(step_depth_, depth); }

void MessageTally::end_step() {
  std::array<std::uint64_t, kMessageKindCount> most{};
  for (const StepCount& c : step_) {
    MessageFlow& f = flow(c.to, c.kind);
    ++f.steps;
    f.max_per_step = std::max(f.max_per_step, c.messages);
    std::uint64_t& m = most[kind_index(c.kind)];
    m = std::max(m, c.messages);
  }
  for (std::size_t k = 0; k < kMessageKindCount; ++k) totals_.rounds[k] += most[k];
  totals_.island_depth_sum += step_depth_;
  totals_.island_depth_max = std::max(totals_.island_depth_max, step_depth_);
  step_.clear();
  step_depth_ = 0;
}

void add_traffic(MessageTraffic& t, const MessageTraffic& m) {
  std::vector<MessageFlow> merged;
  merged.reserve(t.flows.size() + m.flows.size());
  auto a = t.flows.begin();
  auto b = m.flows.begin();
  const auto key = [](const MessageFlow& f) { return std::make_tuple(f.to, f.kind); };
  while (a != t.flows.end() || b != m.flows.end()) {
    if (b == m.flows.end() || (a != t.flows.end() && key(*a) < key(*b))) {
      merged.push_back(*a++);
    } else if (a == t.flows.end() || key(*b) < key(*a)) {
      merged.push_back(*b++);
    } else {
      MessageFlow f = *a++;
      f.messages += b->messages;
      f.bytes += b->bytes;
      f.steps += b->steps;
      f.max_per_step = std::max(f.max_per_step, b->max_per_step);
      ++b;
      merged.push_back(f);
    }
  }
  t.flows = std::move(merged);
  for (std::size_t k = 0; k < kMessageKindCount; ++k) t.rounds[k] += m.rounds[k];
  t.island_depth_sum += m.island_depth_sum;
  t.island_depth_max = std::max(t.island_depth_max, m.island_depth_max);
}

}  // namespace soda
