// rollback/ — buffers, snapshots and repair. This header: the circular
// transform buffer, one per world. The world's thread (the writer) publishes
// one TransformEntry per step, running ahead of its consumers by at most
// capacity() entries (its anticipation); readers (renderer, recorder, the
// runtime's whole-scene reads) each follow their own cursor. See
// docs/transform-buffer.md.
//
// Invariants (kept by every member, under the buffer's mutex):
//  1. An entry being rewritten is never readable: a published entry is
//     immutable, and a rewrite is a new entry, published whole with a new
//     revision. A reader gets a whole entry of one step and one revision, or
//     nothing — never a mix.
//  2. Held entries have consecutive steps, strictly increasing times, and
//     there are at most capacity() of them.
//  3. Freeing rule: the entry of step s is freed as soon as
//       s <= commit_step()  and  s < cursor(r) for every reader r.
//     So the entry at a reader's cursor stays held while the cursor is on it
//     (the reader can re-read it and interpolate from it to the next one);
//     entries above the commit step are never freed; a reader that has read
//     nothing yet pins every held entry; with no reader, committed entries
//     are freed at once, so a writer that commits never stalls for good.
//  4. Per step, revisions strictly increase: 0 when first published, and one
//     more than the last published revision after each invalidation.
//  5. Steps at or below the commit step are never invalidated.
//  6. The lock is held for O(log capacity + readers) work only: entries are
//     handed out as shared pointers, copied and interpolated outside it, and
//     freed entries are destroyed outside it. Waits block on condition
//     variables; nothing spins.
//
// Example (one writer, one renderer):
//   TransformBuffer<float> buffer(64);                // 64 steps of lead
//   // world thread:
//   if (!buffer.publish(std::move(entry))) return;    // false once stopped
//   buffer.set_commit_step(gvt);                      // from the runtime
//   // render thread:
//   auto reader = buffer.add_reader();
//   if (auto sample = buffer.interpolate(reader, frame_time)) draw(sample->poses);
//   // shutdown: buffer.stop(), join the threads, then destroy the buffer.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <vector>

#include "soda/rollback/transform_entry.h"

namespace soda {

/// Handle of one reader of one TransformBuffer; never reused by that buffer.
enum class BufferReaderId : std::uint32_t {};

template <class Real>
struct StoredEntry;  // internal (rollback/src/stored_entry.h)
template <class Real>
class DeltaEncoder;  // internal (rollback/src/delta_encoder.h)

/// What a buffer's held entries take in memory (TransformBuffer::memory()),
/// bytes. Readers' copies of rebuilt entries are theirs, not counted.
struct BufferMemory {
  std::size_t entries = 0;      // held entries
  std::size_t key_entries = 0;  // distinct key entries they use (held or not)
  std::size_t delta_bytes = 0;  // the held entries' own storage (bookkeeping, changed poses, removed ids)
  std::size_t key_bytes = 0;    // the key entries' poses and bookkeeping, each key once
  std::size_t total() const { return delta_bytes + key_bytes; }
};

/// Circular transform buffer of one world. Real: float or double (explicitly
/// instantiated for both).
///
/// Thread safety: every member is safe to call from any thread at any time
/// (one internal mutex). The *protocol* is: one writer thread calls publish,
/// try_publish and invalidate_from (their step order is only meaningful from
/// one thread); any thread may call set_commit_step and stop; each reader id
/// is used by one thread at a time (two threads moving one cursor get
/// well-defined but meaningless cursor positions). The destructor must not
/// run while another thread is inside a member: stop(), join, then destroy.
///
/// Returned EntryPtrs stay valid for as long as the caller holds them, even
/// after the buffer freed or invalidated that entry (an invalidated entry is
/// simply stale: a newer revision of its step exists or will).
///
/// Errors: misuse throws, never UB — std::invalid_argument for bad arguments
/// (capacity 0, unknown reader, unsorted poses, non-finite time),
/// std::logic_error for protocol violations (out-of-order step, time not
/// increasing, invalidating a committed step, lowering the commit step).
template <class Real>
class TransformBuffer {
 public:
  using Pose = BodyPose<Real>;
  using Entry = TransformEntry<Real>;
  using EntryPtr = std::shared_ptr<const Entry>;
  using Sample = PoseSample<Real>;
  using ReaderId = BufferReaderId;

  /// "No step": the commit step before any set_commit_step, and the cursor
  /// of a reader that has read nothing yet. Not a valid entry step.
  static constexpr std::int64_t kNoStep = std::numeric_limits<std::int64_t>::min();

  /// capacity: the most entries held at once (the maximum anticipation, in
  /// steps). delta: store each entry as the poses that differ from a shared
  /// key entry (docs/transform-buffer.md, "Delta entries"; readers get the
  /// same full entries either way); false stores every pose of every entry.
  /// Throws std::invalid_argument if capacity is 0.
  explicit TransformBuffer(std::size_t capacity, bool delta = true);
  TransformBuffer(const TransformBuffer&) = delete;
  TransformBuffer& operator=(const TransformBuffer&) = delete;
  ~TransformBuffer();

  // --- writer -------------------------------------------------------------

  /// Publishes `entry` if there is room; never waits. On success the entry is
  /// moved from and becomes readable whole, with entry.revision overwritten
  /// by the buffer (invariant 4); on false (full) `entry` is left untouched,
  /// and the writer may stop anticipating. The step must be the one after
  /// the last published (any step for the first publish; t after
  /// invalidate_from(t)), and its time later than the previous step's when
  /// the buffer still knows it; else std::logic_error. Poses must be strictly
  /// increasing by id and the time finite; else std::invalid_argument.
  /// Writer thread.
  bool try_publish(Entry&& entry);

  /// As try_publish, but waits while the buffer is full. Returns false, with
  /// `entry` untouched, if stop() was called before room was found; after
  /// stop() it never waits. Writer thread.
  bool publish(Entry&& entry);

  /// Drops every held entry with step >= `step`; publishing restarts at
  /// `step`, and each republished step gets the dropped revision + 1. Readers
  /// whose cursor is at or past `step` are moved back to `step - 1`: their
  /// next read_next returns the new revision of `step`. No-op if nothing at
  /// or after `step` was published. Throws std::logic_error if `step` <=
  /// commit_step(). Releases a writer waiting for room. Writer thread.
  void invalidate_from(std::int64_t step);

  /// Sets the commit step (the horizon below which no world can change this
  /// one's past, e.g. GVT): entries at or below it may be freed once no
  /// reader needs them (invariant 3), and are never invalidated. Repeating
  /// the value is a no-op; lowering it throws std::logic_error. May free
  /// entries and release a waiting writer. Any thread.
  void set_commit_step(std::int64_t step);

  /// Raises the commit step to `step`, but never to the newest published
  /// step or above (the newest entry stays readable); a no-op if that is
  /// not higher than the commit step now. Unlike set_commit_step, several
  /// threads may raise it at once (a writer and the runtime following the
  /// commit horizon). May free entries and release a waiting writer. Any
  /// thread.
  void raise_commit_step(std::int64_t step);

  /// The step of the newest entry published (held or freed), kNoStep before
  /// the first publish; after invalidate_from(t), t - 1. Any thread.
  std::int64_t newest_step() const;

  /// The step of the newest entry freed, kNoStep before the first: every
  /// entry at or before it is gone for good (freed entries are at or below
  /// the commit step, which no invalidation reaches). An entry after it that
  /// is not held is still to come: not published yet, or dropped by
  /// invalidate_from and to be republished — read_at finds nothing at or
  /// before a time in that gap when a rollback emptied the buffer past it.
  /// Only grows. Any thread.
  std::int64_t freed_step() const;

  /// Releases every waiter and makes all later waits return at once
  /// (publish -> false when full, wait_next -> null when nothing is next,
  /// wait_for_time -> false when not reached). Irreversible. Any thread.
  void stop();

  // --- readers ------------------------------------------------------------

  /// Registers a reader whose cursor is kNoStep: it pins every held entry
  /// until it reads (invariant 3). Any thread.
  ReaderId add_reader();

  /// Unregisters a reader; its pins go (may free entries, release the
  /// writer). A thread waiting in wait_next for it gets
  /// std::invalid_argument. Throws std::invalid_argument if unknown.
  void remove_reader(ReaderId reader);

  /// The held entry right after the reader's cursor (the oldest held entry
  /// if the cursor is before it), moving the cursor onto it; null, cursor
  /// unchanged, if there is none yet. Never waits. Reader's thread.
  EntryPtr read_next(ReaderId reader);

  /// As read_next, but waits until there is a next entry; returns null only
  /// once stop() was called and nothing is next. Reader's thread.
  EntryPtr wait_next(ReaderId reader);

  /// The held entry closest to `time` at or before it (the newest entry when
  /// `time` is later than all), moving the cursor onto it — forward or back.
  /// Null, cursor unchanged, if no held entry is at or before `time` (not yet
  /// published, or already freed: keep the previous frame). Throws
  /// std::invalid_argument if `time` is NaN. Reader's thread.
  EntryPtr read_at(ReaderId reader, double time);

  /// As read_at, without a reader: moves no cursor, pins nothing (the entry
  /// may be freed right after; the returned pointer stays valid). Any thread.
  EntryPtr read_at(double time) const;

  /// Poses at `time`, interpolated between the entry at or before it and the
  /// next one (interpolate_entries); the newest entry's poses, unchanged, at
  /// or after the newest time (no extrapolation). Moves the cursor onto the
  /// `before` entry, as read_at. nullopt if no held entry is at or before
  /// `time`. The interpolation runs outside the lock. Reader's thread.
  std::optional<Sample> interpolate(ReaderId reader, double time);

  /// As interpolate, without a reader (no cursor, no pin). Any thread.
  std::optional<Sample> interpolate(double time) const;

  /// Waits until an entry with time >= `time` is published (true), or stop()
  /// was called first (false). Any thread. Beware: a registered reader that
  /// waits here holds its pins; one that has read nothing yet pins every held
  /// entry, so it must read (e.g. read_at) before waiting, or a full buffer
  /// stalls the writer for good.
  bool wait_for_time(double time) const;

  // --- observers (any thread; a snapshot that may be stale on return) -----

  std::size_t capacity() const noexcept { return capacity_; }
  std::size_t size() const;
  /// Newest published, not invalidated step; nullopt if none.
  std::optional<std::int64_t> latest_step() const;
  /// Time of latest_step(); nullopt if none.
  std::optional<double> latest_time() const;
  /// Oldest held step; nullopt if nothing is held.
  std::optional<std::int64_t> oldest_step() const;
  std::int64_t commit_step() const;
  /// Step of the entry the reader last received (kNoStep before its first
  /// read); moved back by invalidate_from. Throws if the reader is unknown.
  std::int64_t cursor(ReaderId reader) const;
  std::size_t reader_count() const;
  bool stopped() const;
  /// Whether entries are stored as deltas (the constructor's `delta`).
  bool delta() const noexcept;
  /// Bytes the held entries take now: O(held entries) under the lock.
  BufferMemory memory() const;

 private:
  struct Reader {
    ReaderId id;
    std::int64_t cursor = kNoStep;
  };
  struct StepTime {
    std::int64_t step;
    double time;
  };
  using StoredPtr = std::shared_ptr<const StoredEntry<Real>>;
  using Garbage = std::vector<StoredPtr>;  // freed under the lock, destroyed after

  static void check_entry(const Entry& entry);
  void check_order(std::int64_t step, double time) const;
  bool push(std::shared_ptr<StoredEntry<Real>> stored, const std::shared_ptr<Entry>& new_key, Garbage& garbage);
  bool publish_with(Entry&& entry, bool wait);
  const StoredPtr& held(std::size_t index) const;
  std::size_t count_at_or_before(double time) const;
  std::size_t next_index(const Reader& reader) const;
  std::optional<StepTime> latest() const;
  Reader* find_reader(ReaderId reader);
  const Reader* find_reader(ReaderId reader) const;
  Reader& reader_or_throw(ReaderId reader, const char* caller);
  bool free_entries(Garbage& garbage);

  const std::size_t capacity_;
  std::mutex writer_mutex_;                  // the encoder (publish, try_publish)
  std::unique_ptr<DeltaEncoder<Real>> encoder_;
  mutable std::mutex mutex_;
  mutable std::condition_variable room_cv_;  // writer: entries freed or dropped, stop
  mutable std::condition_variable data_cv_;  // readers: entry published, reader removed, stop
  std::vector<StoredPtr> ring_;              // capacity_ slots
  std::size_t head_ = 0;                     // slot of the oldest held entry
  std::size_t count_ = 0;                    // held entries
  std::optional<std::int64_t> next_step_;    // step the next publish must carry
  std::optional<StepTime> last_freed_;       // newest freed entry
  std::map<std::int64_t, std::uint64_t> dropped_revisions_;  // step -> last revision dropped
  std::int64_t commit_step_ = kNoStep;
  std::vector<Reader> readers_;
  std::uint32_t next_reader_id_ = 0;
  bool stopped_ = false;
};

extern template class TransformBuffer<float>;
extern template class TransformBuffer<double>;

}  // namespace soda
