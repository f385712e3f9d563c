// Internal: how a TransformBuffer holds one published step (docs/
// transform-buffer.md, "Delta entries"). A *key* entry holds every pose; any
// other entry holds only the poses that differ (bit for bit) from its key
// entry's, the bodies it lacks, and shares the key. Readers get the full
// TransformEntry, rebuilt exactly (full_entry).
//
// Thread safety: immutable once pushed into the buffer, except `cache`,
// which is guarded by `cache_mutex`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <vector>

#include "soda/rollback/transform_entry.h"

namespace soda {

template <class Real>
struct StoredEntry {
  std::int64_t step = 0;
  double time = 0.0;
  std::uint64_t revision = 0;  // set by the buffer as it pushes the entry
  double busy_seconds = 0.0;
  /// This entry itself, whole, when is_key (then changed and removed are
  /// empty); else the key entry the delta is relative to (shared with the
  /// other entries of that key).
  std::shared_ptr<const TransformEntry<Real>> key;
  bool is_key = false;
  std::vector<BodyPose<Real>> changed;  // ascending id: not in key, or not bit-equal to key's pose
  std::vector<BodyId> removed;          // ascending: key's bodies this entry lacks
  /// The entry's contacts when not is_key (a key holds its own), as published.
  std::vector<PairContact<Real>> contacts;
  /// The rebuilt full entry while some reader holds it (readers of one entry
  /// share one copy).
  mutable std::mutex cache_mutex;
  mutable std::weak_ptr<const TransformEntry<Real>> cache;

  /// Bytes this entry holds beyond its key (0 beyond the struct for a key).
  std::size_t delta_bytes() const {
    return sizeof(*this) + changed.capacity() * sizeof(BodyPose<Real>) + removed.capacity() * sizeof(BodyId) +
           contacts.capacity() * sizeof(PairContact<Real>);
  }
};

/// True when the two poses are the same bits (id, every number, sleeping).
template <class Real>
bool same_pose_bits(const BodyPose<Real>& a, const BodyPose<Real>& b);

/// The entry as published: `stored.key` itself for a key entry, else the key's
/// poses with `changed` merged in and `removed` left out, and the stored
/// step, time, revision, busy_seconds and contacts. Exact: every pose is the bits
/// published. O(key poses) for a delta entry, once per entry while a
/// reader holds the result. Any thread.
template <class Real>
std::shared_ptr<const TransformEntry<Real>> full_entry(const StoredEntry<Real>& stored);

}  // namespace soda
