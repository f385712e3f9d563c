// Internal: the writer's side of a TransformBuffer's delta entries
// (stored_entry.h; docs/transform-buffer.md, "Delta entries"): turns each
// published full entry into a StoredEntry relative to the current key entry,
// and decides when an entry becomes the next key.
//
// The key rule (the memory a buffered step costs follows what changes):
// let K be the key's poses, d the poses this entry differs from the key in
// (changed, new or removed), a those it differs from the previous entry in.
// The entry is a new key when
//   - there is no key yet, or delta entries are off;
//   - d * kKeyShareDivisor >= K: the delta is as large as half the table;
//   - d - a > a + K / capacity: the bodies that changed since the key but
//     not since the previous entry (moved, then stopped) outweigh both what
//     moved this step and the key's share of a full buffer.
// So a delta entry holds at most 2a + K / capacity + (one step's change)
// poses, and a key is made at most once per (K / capacity) stale bodies.
//
// Thread safety: none; the buffer calls it under its writer mutex.
#pragma once

#include <cstddef>
#include <memory>

#include "stored_entry.h"

namespace soda {

template <class Real>
class DeltaEncoder {
 public:
  /// delta: false makes every entry a key (every pose stored each step, as
  /// before delta entries). capacity: the buffer's, for the key rule.
  DeltaEncoder(bool delta, std::size_t capacity) : delta_(delta), capacity_(capacity) {}

  struct Encoded {
    std::shared_ptr<StoredEntry<Real>> stored;
    /// The stored entry's key when it is a new key (its revision is still
    /// to be set by the buffer); null otherwise.
    std::shared_ptr<TransformEntry<Real>> new_key;
  };

  /// Encodes `full` (poses strictly increasing by id), moving from it.
  /// O(poses of full + poses of the key).
  Encoded encode(TransformEntry<Real>&& full);

  bool delta() const { return delta_; }

 private:
  Encoded make_key(TransformEntry<Real>&& full);

  const bool delta_;
  const std::size_t capacity_;
  std::shared_ptr<const TransformEntry<Real>> key_;
  std::shared_ptr<const StoredEntry<Real>> previous_;  // the last encoded entry
};

extern template class DeltaEncoder<float>;
extern template class DeltaEncoder<double>;

}  // namespace soda
