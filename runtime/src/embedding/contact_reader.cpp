// ContactReader: contact events per committed step from every world's
// transform buffer (contact_reader.h, docs/contact-events.md).
//
// A read of step s needs the contacts of s - 1 too (to tell begin from
// persist, and to find the ends). They are kept from the previous read when
// it was s - 1; otherwise they are looked up without moving the cursors
// (the cursors, at or before s - 1, keep that entry from being freed), and
// only then are the cursors moved to s, as SceneReader's are (every cursor,
// in every pass: scene_reader.cpp says why a read then cannot deadlock).
#include "soda/runtime/contact_reader.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>

#include "embedding/simulation_core.h"
#include "soda/scene/fnv1a.h"

namespace soda {
namespace {

using Entries = std::vector<std::shared_ptr<const TransformEntry<btScalar>>>;

bool before(const PairContact<btScalar>& x, const PairContact<btScalar>& y) {
  return std::make_pair(x.a, x.b) < std::make_pair(y.a, y.b);
}

// Every world's contacts of one step, by pair; a pair twice is a bug.
std::vector<PairContact<btScalar>> merged(std::int64_t step, const Entries& entries) {
  std::vector<PairContact<btScalar>> out;
  for (const auto& e : entries) out.insert(out.end(), e->contacts.begin(), e->contacts.end());
  std::sort(out.begin(), out.end(), before);
  for (std::size_t i = 1; i < out.size(); ++i)
    if (out[i].a == out[i - 1].a && out[i].b == out[i - 1].b)
      throw std::logic_error("ContactReader: pair " + std::to_string(out[i].a) + "-" + std::to_string(out[i].b) +
                             " is reported by two worlds at step " + std::to_string(step));
  return out;
}

ContactEvent event_of(std::int64_t step, ContactEventKind kind, const PairContact<btScalar>& c, bool with_points) {
  ContactEvent e;
  e.step = step;
  e.kind = kind;
  e.a = c.a;
  e.b = c.b;
  if (with_points) {
    e.point_count = c.point_count;
    for (std::uint32_t i = 0; i < c.point_count; ++i) e.points[i] = c.points[i];
  }
  return e;
}

// Events of `now` against `previous` (both by pair), ascending by pair.
std::vector<ContactEvent> diff(std::int64_t step, const std::vector<PairContact<btScalar>>& previous,
                               const std::vector<PairContact<btScalar>>& now, bool persist) {
  std::vector<ContactEvent> out;
  std::size_t i = 0, j = 0;
  while (i < previous.size() || j < now.size()) {
    if (j == now.size() || (i < previous.size() && before(previous[i], now[j]))) {
      out.push_back(event_of(step, ContactEventKind::End, previous[i++], false));
    } else if (i == previous.size() || before(now[j], previous[i])) {
      out.push_back(event_of(step, ContactEventKind::Begin, now[j++], true));
    } else {
      if (persist) out.push_back(event_of(step, ContactEventKind::Persist, now[j], true));
      ++i, ++j;
    }
  }
  return out;
}

}  // namespace

const char* to_string(ContactEventKind kind) {
  switch (kind) {
    case ContactEventKind::Begin: return "begin";
    case ContactEventKind::Persist: return "persist";
    case ContactEventKind::End: return "end";
  }
  return "?";
}

btScalar ContactEvent::total_impulse() const {
  btScalar sum = 0;
  for (std::uint32_t i = 0; i < point_count; ++i) sum += points[i].impulse;
  return sum;
}

std::uint64_t contact_stream_hash(const std::vector<ContactStep>& steps) {
  std::uint64_t h = kFnv1aOffset;
  for (const ContactStep& s : steps) {
    for (const ContactEvent& e : s.events) {
      fnv1a_mix(h, &e.step, sizeof e.step);
      const auto kind = static_cast<std::uint8_t>(e.kind);
      fnv1a_mix(h, &kind, sizeof kind);
      fnv1a_mix(h, &e.a, sizeof e.a);
      fnv1a_mix(h, &e.b, sizeof e.b);
      fnv1a_mix(h, &e.point_count, sizeof e.point_count);
      for (std::uint32_t i = 0; i < e.point_count; ++i) {
        const ContactEventPoint& p = e.points[i];
        fnv1a_mix(h, p.position_on_a, sizeof p.position_on_a);
        fnv1a_mix(h, p.position_on_b, sizeof p.position_on_b);
        fnv1a_mix(h, p.normal_on_b, sizeof p.normal_on_b);
        fnv1a_mix(h, &p.distance, sizeof p.distance);
        fnv1a_mix(h, &p.impulse, sizeof p.impulse);
      }
    }
  }
  return h;
}

ContactReader::ContactReader(std::shared_ptr<SimulationCore> core, bool persist)
    : core_(std::move(core)), persist_(persist) {
  for (auto& b : core_->buffers) ids_.push_back(b->add_reader());
}

ContactReader::ContactReader(ContactReader&& other) noexcept
    : core_(std::move(other.core_)),
      ids_(std::move(other.ids_)),
      persist_(other.persist_),
      last_step_(other.last_step_),
      last_(std::move(other.last_)),
      held_step_(other.held_step_),
      held_(std::move(other.held_)) {
  other.ids_.clear();
}

ContactReader& ContactReader::operator=(ContactReader&& other) noexcept {
  if (this != &other) {
    release();
    core_ = std::move(other.core_);
    ids_ = std::move(other.ids_);
    other.ids_.clear();
    persist_ = other.persist_;
    last_step_ = other.last_step_;
    last_ = std::move(other.last_);
    held_step_ = other.held_step_;
    held_ = std::move(other.held_);
  }
  return *this;
}

ContactReader::~ContactReader() { release(); }

void ContactReader::release() noexcept {
  if (!core_ || ids_.empty()) return;
  try {
    for (std::size_t w = 0; w < ids_.size(); ++w) core_->buffers[w]->remove_reader(ids_[w]);
    core_->control.wake();  // entries it held may be free now
  } catch (...) {
  }
  ids_.clear();
}

std::optional<ContactStep> ContactReader::read(std::int64_t step, bool wait) {
  if (!core_ || ids_.empty()) throw std::logic_error("ContactReader: used after being moved from");
  if (!core_->contacts)
    throw std::logic_error("ContactReader: contact events are off (SimulationConfig::contact_events)");
  if (step < core_->first_step)
    throw std::invalid_argument("ContactReader: step " + std::to_string(step) + " is before the run's first step " +
                                std::to_string(core_->first_step));
  if (step == last_step_) return last_;
  if (step < last_step_) return std::nullopt;
  Entries entries;
  for (;;) {
    const std::uint64_t seen = core_->control.watch_epoch();
    Gathered got = Gathered::Frame;
    // The step before: kept, or looked up behind unmoved cursors.
    if (step > core_->first_step && held_step_ != step - 1) {
      got = gather_entries(*core_, ids_, step - 1, false, entries);
      if (got == Gathered::Frame) {
        held_ = merged(step - 1, entries);
        held_step_ = step - 1;
      }
    }
    if (got == Gathered::Frame) got = gather_entries(*core_, ids_, step, true, entries);
    if (got == Gathered::Frame) {
      std::vector<PairContact<btScalar>> now = merged(step, entries);
      static const std::vector<PairContact<btScalar>> kNone;
      ContactStep out;
      out.step = step;
      out.time = core_->time_of(step);
      out.events = diff(step, step > core_->first_step ? held_ : kNone, now, persist_);
      held_ = std::move(now);
      held_step_ = step;
      last_step_ = step;
      last_ = out;
      return out;
    }
    if (got == Gathered::Gone || !wait) return std::nullopt;
    core_->control.rethrow_if_failed();
    if (core_->control.stopping()) return std::nullopt;
    core_->control.wait_watch(seen);
  }
}

std::optional<ContactStep> ContactReader::read_step(std::int64_t step) { return read(step, true); }

std::optional<ContactStep> ContactReader::try_read_step(std::int64_t step) { return read(step, false); }

std::optional<ContactStep> ContactReader::read_next() {
  return read(last_step_ < 0 ? (core_ ? core_->first_step : 0) : last_step_ + 1, true);
}

}  // namespace soda
