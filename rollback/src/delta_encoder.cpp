// The writer's side of delta entries: see delta_encoder.h for the key rule.
#include "delta_encoder.h"

#include <algorithm>
#include <cstring>
#include <utility>

namespace soda {
namespace {

// A new key once a delta holds as many poses as 1 / kKeyShareDivisor of the
// key: past half the table, sharing the key saves less than it costs to
// rebuild entries from it.
constexpr std::size_t kKeyShareDivisor = 2;

// Items in exactly one of two lists ascending by id_of, plus those in both
// that `same` finds different.
template <class T, class IdOf, class Same>
std::size_t count_differing(const std::vector<T>& a, const std::vector<T>& b, IdOf id_of, Same same) {
  std::size_t i = 0, j = 0, n = 0;
  while (i < a.size() && j < b.size()) {
    if (id_of(a[i]) < id_of(b[j])) {
      ++n, ++i;
    } else if (id_of(b[j]) < id_of(a[i])) {
      ++n, ++j;
    } else {
      n += same(a[i], b[j]) ? 0 : 1;
      ++i, ++j;
    }
  }
  return n + (a.size() - i) + (b.size() - j);
}

// Ids in exactly one of two ascending pose lists, or in both with different
// poses.
template <class Real>
std::size_t changed_between(const std::vector<BodyPose<Real>>& a, const std::vector<BodyPose<Real>>& b) {
  return count_differing(a, b, [](const BodyPose<Real>& p) { return p.id; }, same_pose_bits<Real>);
}

// Ids in exactly one of two ascending id lists.
std::size_t ids_between(const std::vector<BodyId>& a, const std::vector<BodyId>& b) {
  return count_differing(a, b, [](BodyId id) { return id; }, [](BodyId, BodyId) { return true; });
}

}  // namespace

template <class Real>
bool same_pose_bits(const BodyPose<Real>& a, const BodyPose<Real>& b) {
  return a.id == b.id && a.sleeping == b.sleeping && std::memcmp(a.position, b.position, sizeof a.position) == 0 &&
         std::memcmp(a.orientation, b.orientation, sizeof a.orientation) == 0 &&
         std::memcmp(a.linear_velocity, b.linear_velocity, sizeof a.linear_velocity) == 0 &&
         std::memcmp(a.angular_velocity, b.angular_velocity, sizeof a.angular_velocity) == 0;
}

template <class Real>
std::shared_ptr<const TransformEntry<Real>> full_entry(const StoredEntry<Real>& stored) {
  if (stored.is_key) return stored.key;
  std::lock_guard lock(stored.cache_mutex);
  if (auto cached = stored.cache.lock()) return cached;
  auto out = std::make_shared<TransformEntry<Real>>();
  out->step = stored.step;
  out->time = stored.time;
  out->revision = stored.revision;
  out->busy_seconds = stored.busy_seconds;
  out->contacts = stored.contacts;
  const std::vector<BodyPose<Real>>& key = stored.key->poses;
  const std::vector<BodyPose<Real>>& changed = stored.changed;
  const std::vector<BodyId>& removed = stored.removed;
  out->poses.reserve(key.size() + changed.size());
  std::size_t c = 0, r = 0;
  for (const BodyPose<Real>& k : key) {
    while (c < changed.size() && changed[c].id < k.id) out->poses.push_back(changed[c++]);
    if (c < changed.size() && changed[c].id == k.id) {
      out->poses.push_back(changed[c++]);
      continue;
    }
    while (r < removed.size() && removed[r] < k.id) ++r;
    if (r < removed.size() && removed[r] == k.id) continue;
    out->poses.push_back(k);
  }
  while (c < changed.size()) out->poses.push_back(changed[c++]);
  std::shared_ptr<const TransformEntry<Real>> result = std::move(out);
  stored.cache = result;
  return result;
}

template <class Real>
auto DeltaEncoder<Real>::make_key(TransformEntry<Real>&& full) -> Encoded {
  Encoded e;
  full.poses.shrink_to_fit();  // a key may be held for long: no growth slack (a no-op when reserved)
  e.new_key = std::make_shared<TransformEntry<Real>>(std::move(full));
  e.stored = std::make_shared<StoredEntry<Real>>();
  e.stored->step = e.new_key->step;
  e.stored->time = e.new_key->time;
  e.stored->busy_seconds = e.new_key->busy_seconds;
  e.stored->key = e.new_key;
  e.stored->is_key = true;
  key_ = e.new_key;
  previous_ = e.stored;
  return e;
}

template <class Real>
auto DeltaEncoder<Real>::encode(TransformEntry<Real>&& full) -> Encoded {
  if (!delta_ || !key_) return make_key(std::move(full));
  const std::vector<BodyPose<Real>>& key = key_->poses;
  const std::vector<BodyPose<Real>>& poses = full.poses;
  auto stored = std::make_shared<StoredEntry<Real>>();
  const std::size_t limit = key.size() / kKeyShareDivisor;
  std::size_t i = 0, j = 0;
  while (i < poses.size() || j < key.size()) {
    if (stored->changed.size() + stored->removed.size() >= limit) return make_key(std::move(full));
    if (j == key.size() || (i < poses.size() && poses[i].id < key[j].id)) {
      stored->changed.push_back(poses[i++]);  // a body the key lacks
    } else if (i == poses.size() || key[j].id < poses[i].id) {
      stored->removed.push_back(key[j++].id);
    } else {
      if (!same_pose_bits(poses[i], key[j])) stored->changed.push_back(poses[i]);
      ++i, ++j;
    }
  }
  const std::size_t d = stored->changed.size() + stored->removed.size();
  if (d >= limit && d > 0) return make_key(std::move(full));
  // a: what differs from the previous entry (both are relative to key_; a
  // key's own delta is empty).
  std::size_t a = d;
  if (previous_ && previous_->key == key_)
    a = changed_between(stored->changed, previous_->changed) + ids_between(stored->removed, previous_->removed);
  if (d - std::min(a, d) > a + key.size() / capacity_) return make_key(std::move(full));
  stored->changed.shrink_to_fit();
  stored->removed.shrink_to_fit();
  stored->step = full.step;
  stored->time = full.time;
  stored->busy_seconds = full.busy_seconds;
  stored->contacts = std::move(full.contacts);
  stored->contacts.shrink_to_fit();
  stored->key = key_;
  previous_ = stored;
  return {std::move(stored), nullptr};
}

template bool same_pose_bits<float>(const BodyPose<float>&, const BodyPose<float>&);
template bool same_pose_bits<double>(const BodyPose<double>&, const BodyPose<double>&);
template std::shared_ptr<const TransformEntry<float>> full_entry<float>(const StoredEntry<float>&);
template std::shared_ptr<const TransformEntry<double>> full_entry<double>(const StoredEntry<double>&);
template class DeltaEncoder<float>;
template class DeltaEncoder<double>;

}  // namespace soda
