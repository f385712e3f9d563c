// The circular transform buffer: a ring of immutable, shared entries guarded
// by one mutex. See transform_buffer.h for the invariants and contracts.
#include "soda/rollback/transform_buffer.h"

#include "delta_encoder.h"
#include "stored_entry.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

namespace soda {
namespace {

std::string reader_text(BufferReaderId reader) {
  return std::to_string(static_cast<std::uint32_t>(reader));
}

}  // namespace

template <class Real>
TransformBuffer<Real>::TransformBuffer(std::size_t capacity, bool delta) : capacity_(capacity) {
  if (capacity == 0) {
    throw std::invalid_argument("TransformBuffer: capacity must be at least 1 entry");
  }
  encoder_ = std::make_unique<DeltaEncoder<Real>>(delta, capacity);
  ring_.resize(capacity);
}

template <class Real>
TransformBuffer<Real>::~TransformBuffer() = default;

// --- writer ---------------------------------------------------------------

template <class Real>
bool TransformBuffer<Real>::try_publish(Entry&& entry) {
  return publish_with(std::move(entry), false);
}

template <class Real>
bool TransformBuffer<Real>::publish(Entry&& entry) {
  return publish_with(std::move(entry), true);
}

// Room is found under the lock, the entry encoded outside it (O(poses)), then
// pushed under it. Only the writer adds entries and the writer mutex is held
// throughout, so the room found is still there when the entry is pushed.
template <class Real>
bool TransformBuffer<Real>::publish_with(Entry&& entry, bool wait) {
  check_entry(entry);
  std::lock_guard writer(writer_mutex_);
  {
    std::unique_lock lock(mutex_);
    check_order(entry.step, entry.time);  // report misuse before waiting
    if (wait) room_cv_.wait(lock, [&] { return count_ < capacity_ || stopped_; });
    if (count_ == capacity_) return false;  // full (stopped while full)
    check_order(entry.step, entry.time);    // another thread may have invalidated meanwhile
  }
  auto encoded = encoder_->encode(std::move(entry));
  Garbage garbage;  // freed entries, destroyed after the lock is released
  bool freed = false;
  {
    std::lock_guard lock(mutex_);
    check_order(encoded.stored->step, encoded.stored->time);
    freed = push(std::move(encoded.stored), encoded.new_key, garbage);
  }
  if (freed) room_cv_.notify_all();
  data_cv_.notify_all();
  return true;
}

template <class Real>
void TransformBuffer<Real>::invalidate_from(std::int64_t step) {
  Garbage garbage;
  {
    std::lock_guard lock(mutex_);
    if (step <= commit_step_) {
      throw std::logic_error("TransformBuffer::invalidate_from(" + std::to_string(step) +
                             "): steps at or below the commit step " +
                             std::to_string(commit_step_) + " can no longer change");
    }
    if (!next_step_ || step >= *next_step_) return;  // nothing at or after `step`
    while (count_ > 0 && held(count_ - 1)->step >= step) {
      StoredPtr& slot = ring_[(head_ + count_ - 1) % capacity_];
      std::uint64_t& last = dropped_revisions_[slot->step];
      last = std::max(last, slot->revision);
      garbage.push_back(std::move(slot));
      --count_;
    }
    next_step_ = step;
    for (Reader& reader : readers_) {
      if (reader.cursor >= step) reader.cursor = step - 1;
    }
  }
  room_cv_.notify_all();
}

template <class Real>
void TransformBuffer<Real>::set_commit_step(std::int64_t step) {
  Garbage garbage;
  {
    std::lock_guard lock(mutex_);
    if (step < commit_step_) {
      throw std::logic_error("TransformBuffer::set_commit_step(" + std::to_string(step) +
                             "): the commit step never goes back (it is " +
                             std::to_string(commit_step_) + ")");
    }
    commit_step_ = step;
    if (!free_entries(garbage)) return;
  }
  room_cv_.notify_all();
}

template <class Real>
void TransformBuffer<Real>::raise_commit_step(std::int64_t step) {
  Garbage garbage;
  {
    std::lock_guard lock(mutex_);
    if (!next_step_) return;  // nothing published yet
    step = std::min(step, *next_step_ - 2);
    if (step <= commit_step_) return;
    commit_step_ = step;
    if (!free_entries(garbage)) return;
  }
  room_cv_.notify_all();
}

template <class Real>
std::int64_t TransformBuffer<Real>::newest_step() const {
  std::lock_guard lock(mutex_);
  return next_step_ ? *next_step_ - 1 : kNoStep;
}

template <class Real>
std::int64_t TransformBuffer<Real>::freed_step() const {
  std::lock_guard lock(mutex_);
  return last_freed_ ? last_freed_->step : kNoStep;
}

template <class Real>
void TransformBuffer<Real>::stop() {
  {
    std::lock_guard lock(mutex_);
    stopped_ = true;
  }
  room_cv_.notify_all();
  data_cv_.notify_all();
}

// --- readers --------------------------------------------------------------

template <class Real>
BufferReaderId TransformBuffer<Real>::add_reader() {
  std::lock_guard lock(mutex_);
  const ReaderId id{next_reader_id_++};
  readers_.push_back(Reader{id, kNoStep});
  return id;
}

template <class Real>
void TransformBuffer<Real>::remove_reader(ReaderId reader) {
  Garbage garbage;
  {
    std::lock_guard lock(mutex_);
    reader_or_throw(reader, "remove_reader");
    std::erase_if(readers_, [&](const Reader& r) { return r.id == reader; });
    free_entries(garbage);
  }
  room_cv_.notify_all();
  data_cv_.notify_all();  // a wait_next on this id must wake and throw
}

template <class Real>
auto TransformBuffer<Real>::read_next(ReaderId reader) -> EntryPtr {
  Garbage garbage;
  StoredPtr entry;
  bool freed = false;
  {
    std::lock_guard lock(mutex_);
    Reader& r = reader_or_throw(reader, "read_next");
    const std::size_t index = next_index(r);
    if (index == count_) return nullptr;
    entry = held(index);
    r.cursor = entry->step;
    freed = free_entries(garbage);
  }
  if (freed) room_cv_.notify_all();
  return full_entry(*entry);
}

template <class Real>
auto TransformBuffer<Real>::wait_next(ReaderId reader) -> EntryPtr {
  Garbage garbage;
  StoredPtr entry;
  bool freed = false;
  {
    std::unique_lock lock(mutex_);
    data_cv_.wait(lock, [&] {
      const Reader* r = find_reader(reader);
      return r == nullptr || stopped_ || next_index(*r) < count_;
    });
    Reader& r = reader_or_throw(reader, "wait_next");
    const std::size_t index = next_index(r);
    if (index == count_) return nullptr;  // stopped, nothing next
    entry = held(index);
    r.cursor = entry->step;
    freed = free_entries(garbage);
  }
  if (freed) room_cv_.notify_all();
  return full_entry(*entry);
}

template <class Real>
auto TransformBuffer<Real>::read_at(ReaderId reader, double time) -> EntryPtr {
  if (std::isnan(time)) throw std::invalid_argument("TransformBuffer::read_at: time is NaN");
  Garbage garbage;
  StoredPtr entry;
  bool freed = false;
  {
    std::lock_guard lock(mutex_);
    Reader& r = reader_or_throw(reader, "read_at");
    const std::size_t n = count_at_or_before(time);
    if (n == 0) return nullptr;
    entry = held(n - 1);
    r.cursor = entry->step;
    freed = free_entries(garbage);
  }
  if (freed) room_cv_.notify_all();
  return full_entry(*entry);
}

template <class Real>
auto TransformBuffer<Real>::read_at(double time) const -> EntryPtr {
  if (std::isnan(time)) throw std::invalid_argument("TransformBuffer::read_at: time is NaN");
  StoredPtr entry;
  {
    std::lock_guard lock(mutex_);
    const std::size_t n = count_at_or_before(time);
    if (n == 0) return nullptr;
    entry = held(n - 1);
  }
  return full_entry(*entry);
}

template <class Real>
auto TransformBuffer<Real>::interpolate(ReaderId reader, double time) -> std::optional<Sample> {
  if (std::isnan(time)) throw std::invalid_argument("TransformBuffer::interpolate: time is NaN");
  Garbage garbage;
  StoredPtr before;
  StoredPtr after;
  bool freed = false;
  {
    std::lock_guard lock(mutex_);
    Reader& r = reader_or_throw(reader, "interpolate");
    const std::size_t n = count_at_or_before(time);
    if (n == 0) return std::nullopt;
    before = held(n - 1);
    after = n < count_ ? held(n) : before;
    r.cursor = before->step;
    freed = free_entries(garbage);
  }
  if (freed) room_cv_.notify_all();
  const EntryPtr b = full_entry(*before);
  return interpolate_entries(*b, before == after ? *b : *full_entry(*after), time);
}

template <class Real>
auto TransformBuffer<Real>::interpolate(double time) const -> std::optional<Sample> {
  if (std::isnan(time)) throw std::invalid_argument("TransformBuffer::interpolate: time is NaN");
  StoredPtr before;
  StoredPtr after;
  {
    std::lock_guard lock(mutex_);
    const std::size_t n = count_at_or_before(time);
    if (n == 0) return std::nullopt;
    before = held(n - 1);
    after = n < count_ ? held(n) : before;
  }
  const EntryPtr b = full_entry(*before);
  return interpolate_entries(*b, before == after ? *b : *full_entry(*after), time);
}

template <class Real>
bool TransformBuffer<Real>::wait_for_time(double time) const {
  if (std::isnan(time)) throw std::invalid_argument("TransformBuffer::wait_for_time: time is NaN");
  std::unique_lock lock(mutex_);
  auto reached = [&] {
    const std::optional<StepTime> newest = latest();
    return newest && newest->time >= time;
  };
  data_cv_.wait(lock, [&] { return stopped_ || reached(); });
  return reached();
}

// --- observers ------------------------------------------------------------

template <class Real>
std::size_t TransformBuffer<Real>::size() const {
  std::lock_guard lock(mutex_);
  return count_;
}

template <class Real>
std::optional<std::int64_t> TransformBuffer<Real>::latest_step() const {
  std::lock_guard lock(mutex_);
  const std::optional<StepTime> newest = latest();
  if (!newest) return std::nullopt;
  return newest->step;
}

template <class Real>
std::optional<double> TransformBuffer<Real>::latest_time() const {
  std::lock_guard lock(mutex_);
  const std::optional<StepTime> newest = latest();
  if (!newest) return std::nullopt;
  return newest->time;
}

template <class Real>
std::optional<std::int64_t> TransformBuffer<Real>::oldest_step() const {
  std::lock_guard lock(mutex_);
  if (count_ == 0) return std::nullopt;
  return held(0)->step;
}

template <class Real>
std::int64_t TransformBuffer<Real>::commit_step() const {
  std::lock_guard lock(mutex_);
  return commit_step_;
}

template <class Real>
std::int64_t TransformBuffer<Real>::cursor(ReaderId reader) const {
  std::lock_guard lock(mutex_);
  const Reader* r = find_reader(reader);
  if (r == nullptr) {
    throw std::invalid_argument("TransformBuffer::cursor: unknown reader id " + reader_text(reader));
  }
  return r->cursor;
}

template <class Real>
std::size_t TransformBuffer<Real>::reader_count() const {
  std::lock_guard lock(mutex_);
  return readers_.size();
}

template <class Real>
bool TransformBuffer<Real>::stopped() const {
  std::lock_guard lock(mutex_);
  return stopped_;
}

template <class Real>
bool TransformBuffer<Real>::delta() const noexcept {
  return encoder_->delta();
}

template <class Real>
BufferMemory TransformBuffer<Real>::memory() const {
  BufferMemory m;
  std::vector<const Entry*> keys;
  std::lock_guard lock(mutex_);
  for (std::size_t i = 0; i < count_; ++i) {
    const StoredEntry<Real>& e = *held(i);
    ++m.entries;
    m.delta_bytes += e.delta_bytes();
    if (std::find(keys.begin(), keys.end(), e.key.get()) != keys.end()) continue;
    keys.push_back(e.key.get());
    m.key_bytes += sizeof(Entry) + e.key->poses.capacity() * sizeof(Pose) +
                   e.key->contacts.capacity() * sizeof(PairContact<Real>);
  }
  m.key_entries = keys.size();
  return m;
}

// --- internals (all but check_entry expect mutex_ held) ------------------

template <class Real>
void TransformBuffer<Real>::check_entry(const Entry& entry) {
  if (entry.step == kNoStep || entry.step == std::numeric_limits<std::int64_t>::max()) {
    throw std::invalid_argument("TransformBuffer::publish: step " + std::to_string(entry.step) +
                                " is reserved");
  }
  if (!std::isfinite(entry.time)) {
    throw std::invalid_argument("TransformBuffer::publish: step " + std::to_string(entry.step) +
                                " has a non-finite time");
  }
  for (std::size_t i = 1; i < entry.poses.size(); ++i) {
    if (!(entry.poses[i - 1].id < entry.poses[i].id)) {
      throw std::invalid_argument("TransformBuffer::publish: step " + std::to_string(entry.step) +
                                  ": poses must be strictly increasing by body id (body " +
                                  std::to_string(entry.poses[i].id) + " follows body " +
                                  std::to_string(entry.poses[i - 1].id) + ")");
    }
  }
  for (std::size_t i = 0; i < entry.contacts.size(); ++i) {
    const PairContact<Real>& c = entry.contacts[i];
    const bool ordered = i == 0 || std::make_pair(entry.contacts[i - 1].a, entry.contacts[i - 1].b) < std::make_pair(c.a, c.b);
    if (!(c.a < c.b) || c.point_count < 1 || c.point_count > 4 || !ordered) {
      throw std::invalid_argument("TransformBuffer::publish: step " + std::to_string(entry.step) + ": contact of pair " +
                                  std::to_string(c.a) + "-" + std::to_string(c.b) +
                                  " out of order, not a < b, or without 1-4 points");
    }
  }
}

template <class Real>
void TransformBuffer<Real>::check_order(std::int64_t step, double time) const {
  if (next_step_ && step != *next_step_) {
    throw std::logic_error("TransformBuffer::publish: step " + std::to_string(step) +
                           " out of order, expected step " + std::to_string(*next_step_) +
                           " (steps are published one after another; after "
                           "invalidate_from(t) publishing restarts at t)");
  }
  const std::optional<StepTime> previous = latest();
  if (previous && previous->step == step - 1 && !(time > previous->time)) {
    throw std::logic_error("TransformBuffer::publish: step " + std::to_string(step) +
                           " has time " + std::to_string(time) +
                           ", not later than step " + std::to_string(previous->step) + "'s " +
                           std::to_string(previous->time));
  }
}

template <class Real>
bool TransformBuffer<Real>::push(std::shared_ptr<StoredEntry<Real>> entry, const std::shared_ptr<Entry>& new_key,
                                 Garbage& garbage) {
  const auto dropped = dropped_revisions_.find(entry->step);
  if (dropped != dropped_revisions_.end()) {
    entry->revision = dropped->second + 1;
    dropped_revisions_.erase(dropped);
  } else {
    entry->revision = 0;
  }
  if (new_key) new_key->revision = entry->revision;
  next_step_ = entry->step + 1;
  // Only this thread can reach the new entry (and its new key) until it is
  // stored in the ring.
  ring_[(head_ + count_) % capacity_] = std::move(entry);
  ++count_;
  return free_entries(garbage);  // a step at or below the commit step goes at once
}

template <class Real>
auto TransformBuffer<Real>::held(std::size_t index) const -> const StoredPtr& {
  return ring_[(head_ + index) % capacity_];
}

template <class Real>
std::size_t TransformBuffer<Real>::count_at_or_before(double time) const {
  std::size_t low = 0;  // times are strictly increasing (invariant 2)
  std::size_t high = count_;
  while (low < high) {
    const std::size_t mid = low + (high - low) / 2;
    if (held(mid)->time <= time) {
      low = mid + 1;
    } else {
      high = mid;
    }
  }
  return low;
}

template <class Real>
std::size_t TransformBuffer<Real>::next_index(const Reader& reader) const {
  if (count_ == 0) return 0;
  const std::int64_t oldest = held(0)->step;
  if (reader.cursor < oldest) return 0;
  // Held steps are consecutive (invariant 2): the cursor's successor is at
  // cursor - oldest + 1, or past the end.
  const std::uint64_t offset = static_cast<std::uint64_t>(reader.cursor - oldest) + 1;
  return offset < count_ ? static_cast<std::size_t>(offset) : count_;
}

template <class Real>
auto TransformBuffer<Real>::latest() const -> std::optional<StepTime> {
  if (count_ > 0) {
    const StoredPtr& newest = held(count_ - 1);
    return StepTime{newest->step, newest->time};
  }
  // Nothing held: the newest step is the last freed one, unless it was
  // invalidated since (then publishing restarts at or before it).
  if (last_freed_ && next_step_ && last_freed_->step == *next_step_ - 1) return last_freed_;
  return std::nullopt;
}

template <class Real>
auto TransformBuffer<Real>::find_reader(ReaderId reader) -> Reader* {
  for (Reader& r : readers_) {
    if (r.id == reader) return &r;
  }
  return nullptr;
}

template <class Real>
auto TransformBuffer<Real>::find_reader(ReaderId reader) const -> const Reader* {
  for (const Reader& r : readers_) {
    if (r.id == reader) return &r;
  }
  return nullptr;
}

template <class Real>
auto TransformBuffer<Real>::reader_or_throw(ReaderId reader, const char* caller) -> Reader& {
  Reader* r = find_reader(reader);
  if (r == nullptr) {
    throw std::invalid_argument(std::string("TransformBuffer::") + caller +
                                ": unknown reader id " + reader_text(reader) +
                                " (never added, or removed)");
  }
  return *r;
}

// Invariant 3: free from the oldest end while s <= commit and s < every cursor.
template <class Real>
bool TransformBuffer<Real>::free_entries(Garbage& garbage) {
  std::int64_t pinned_from = std::numeric_limits<std::int64_t>::max();
  for (const Reader& r : readers_) pinned_from = std::min(pinned_from, r.cursor);
  bool freed = false;
  while (count_ > 0) {
    StoredPtr& oldest = ring_[head_];
    if (oldest->step > commit_step_ || oldest->step >= pinned_from) break;
    last_freed_ = StepTime{oldest->step, oldest->time};
    garbage.push_back(std::move(oldest));
    head_ = (head_ + 1) % capacity_;
    --count_;
    freed = true;
  }
  return freed;
}

template class TransformBuffer<float>;
template class TransformBuffer<double>;

}  // namespace soda
