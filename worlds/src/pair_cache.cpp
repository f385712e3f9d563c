#include "pair_cache.h"

#include <algorithm>
#include <new>
#include <utility>

namespace soda {
namespace {

// Fewest buckets: the table doubles whenever the pairs outnumber them.
constexpr std::size_t kMinBuckets = 64;

// MurmurHash3's 64-bit finaliser: every key bit reaches the low bits that
// pick the bucket (ids of neighbouring bodies differ in their low bits only).
std::uint64_t mix(std::uint64_t k) {
  k ^= k >> 33;
  k *= 0xff51afd7ed558ccdull;
  k ^= k >> 33;
  k *= 0xc4ceb9fe1a85ec53ull;
  k ^= k >> 33;
  return k;
}

// Buckets come in blocks of 2^kBlockBits (256 bytes): pairs whose ids
// agree but for their low kIdRunBits bits share a block (the block from a
// hash of the high bits, the bucket within it from a hash of the whole key).
// Bodies are mostly inserted and torn down in id order and neighbours have
// nearby ids, so consecutive lookups reuse a few cache lines instead of
// missing the cache twice each (1,000,000 cubes: the bucket table is 32 MB).
constexpr int kBlockBits = 8;
constexpr int kIdRunBits = 6;

bool holds(const btBroadphasePair& pair, const btBroadphaseProxy* proxy) {
  return pair.m_pProxy0 == proxy || pair.m_pProxy1 == proxy;
}

// Room for one more element, growing geometrically (reserve(size + 1)
// alone would reallocate at every call).
template <class T>
void make_room(std::vector<T>& v) {
  if (v.size() == v.capacity()) v.reserve(std::max<std::size_t>(2 * v.capacity(), kMinBuckets));
}

}  // namespace

PairCache::PairCache() : head_(kMinBuckets, kNone) {
  pairs_.reserve(2);  // as Bullet's cache
}

std::uint64_t PairCache::key_of(const btBroadphaseProxy* low, const btBroadphaseProxy* high) {
  return std::uint64_t{static_cast<std::uint32_t>(low->m_uniqueId)} |
         (std::uint64_t{static_cast<std::uint32_t>(high->m_uniqueId)} << 32);
}

std::size_t PairCache::bucket_of(std::uint64_t key) const {
  constexpr std::uint64_t kRunMask = ~((std::uint64_t{1} << kIdRunBits) - 1);
  constexpr std::uint64_t kHigh = kRunMask & (kRunMask << 32 | 0xffffffffull);
  const std::uint64_t block = mix(key & kHigh) << kBlockBits;
  const std::uint64_t within = mix(key) & ((std::uint64_t{1} << kBlockBits) - 1);
  return static_cast<std::size_t>(block | within) & (head_.size() - 1);
}

int PairCache::find_index(std::uint64_t key) const {
  int i = head_[bucket_of(key)];
  while (i != kNone && keys_[static_cast<std::size_t>(i)] != key) i = next_[static_cast<std::size_t>(i)];
  return i;
}

// Builds the doubled table aside, then swaps it in: a failed allocation
// leaves the cache as it was.
void PairCache::grow_buckets() {
  std::vector<int> head(head_.size() * 2, kNone);
  head_.swap(head);
  for (std::size_t i = 0; i < keys_.size(); ++i) {
    int& first = head_[bucket_of(keys_[i])];
    next_[i] = first;
    first = static_cast<int>(i);
  }
}

bool PairCache::needsBroadphaseCollision(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) const {
  if (filter_) return filter_->needBroadphaseCollision(proxy0, proxy1);
  return (proxy0->m_collisionFilterGroup & proxy1->m_collisionFilterMask) != 0 &&
         (proxy1->m_collisionFilterGroup & proxy0->m_collisionFilterMask) != 0;
}

btBroadphasePair* PairCache::addOverlappingPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) {
  if (!needsBroadphaseCollision(proxy0, proxy1)) return nullptr;
  if (proxy0->m_uniqueId > proxy1->m_uniqueId) std::swap(proxy0, proxy1);
  const std::uint64_t key = key_of(proxy0, proxy1);
  const int found = find_index(key);
  if (found != kNone) return &pairs_[found];

  // Every allocation before the first change: bad_alloc leaves the cache whole.
  if (keys_.size() + 1 > head_.size()) grow_buckets();
  make_room(keys_);
  make_room(next_);
  const int index = pairs_.size();
  void* slot = &pairs_.expandNonInitializing();
  keys_.push_back(key);
  int& first = head_[bucket_of(key)];
  next_.push_back(first);
  first = index;
  if (ghost_) ghost_->addOverlappingPair(proxy0, proxy1);
  auto* pair = new (slot) btBroadphasePair(*proxy0, *proxy1);
  pair->m_algorithm = nullptr;
  pair->m_internalTmpValue = 0;
  return pair;
}

void* PairCache::removeOverlappingPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1,
                                       btDispatcher* dispatcher) {
  if (proxy0->m_uniqueId > proxy1->m_uniqueId) std::swap(proxy0, proxy1);
  const std::uint64_t key = key_of(proxy0, proxy1);
  const int index = find_index(key);
  if (index == kNone) return nullptr;
  const auto at = static_cast<std::size_t>(index);

  cleanOverlappingPair(pairs_[index], dispatcher);
  void* user_data = pairs_[index].m_internalInfo1;

  // Unlink the pair from its bucket.
  int* link = &head_[bucket_of(key)];
  while (*link != index) link = &next_[static_cast<std::size_t>(*link)];
  *link = next_[at];

  if (ghost_) ghost_->removeOverlappingPair(proxy0, proxy1, dispatcher);

  // The last pair moves into the freed slot (as Bullet's cache): its link
  // now names the slot.
  const int last = pairs_.size() - 1;
  if (index != last) {
    const auto from = static_cast<std::size_t>(last);
    int* to_last = &head_[bucket_of(keys_[from])];
    while (*to_last != last) to_last = &next_[static_cast<std::size_t>(*to_last)];
    *to_last = index;
    next_[at] = next_[from];
    keys_[at] = keys_[from];
    pairs_[index] = pairs_[last];
  }
  pairs_.pop_back();
  keys_.pop_back();
  next_.pop_back();
  return user_data;
}

void PairCache::removeOverlappingPairsContainingProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  if (!proxy_sweeps_) return;
  for (int i = 0; i < pairs_.size();) {
    btBroadphasePair& pair = pairs_[i];
    if (holds(pair, proxy))
      removeOverlappingPair(pair.m_pProxy0, pair.m_pProxy1, dispatcher);
    else
      ++i;
  }
}

void PairCache::cleanOverlappingPair(btBroadphasePair& pair, btDispatcher* dispatcher) {
  if (pair.m_algorithm && dispatcher) {
    pair.m_algorithm->~btCollisionAlgorithm();
    dispatcher->freeCollisionAlgorithm(pair.m_algorithm);
    pair.m_algorithm = nullptr;
  }
}

void PairCache::cleanProxyFromPairs(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  if (!proxy_sweeps_) return;
  for (int i = 0; i < pairs_.size(); ++i)
    if (holds(pairs_[i], proxy)) cleanOverlappingPair(pairs_[i], dispatcher);
}

void PairCache::processAllOverlappingPairs(btOverlapCallback* callback, btDispatcher* dispatcher) {
  for (int i = 0; i < pairs_.size();) {
    btBroadphasePair& pair = pairs_[i];
    if (callback->processOverlap(pair))
      removeOverlappingPair(pair.m_pProxy0, pair.m_pProxy1, dispatcher);
    else
      ++i;
  }
}

// As Bullet's cache: visits the array slots in decreasing (uid0, uid1) order
// of the pairs they held when the walk began; a removal visits the slot again.
void PairCache::processAllOverlappingPairs(btOverlapCallback* callback, btDispatcher* dispatcher,
                                           const btDispatcherInfo& dispatch_info) {
  if (!dispatch_info.m_deterministicOverlappingPairs) {
    processAllOverlappingPairs(callback, dispatcher);
    return;
  }
  struct Slot {
    int index, uid0, uid1;
  };
  std::vector<Slot> order(static_cast<std::size_t>(pairs_.size()));
  for (int i = 0; i < pairs_.size(); ++i)
    order[static_cast<std::size_t>(i)] = {i, pairs_[i].m_pProxy0->m_uniqueId, pairs_[i].m_pProxy1->m_uniqueId};
  std::sort(order.begin(), order.end(), [](const Slot& a, const Slot& b) {
    return a.uid0 > b.uid0 || (a.uid0 == b.uid0 && a.uid1 > b.uid1);
  });
  for (std::size_t i = 0; i < order.size();) {
    if (order[i].index >= pairs_.size()) {  // emptied by removals (Bullet would read past the end)
      ++i;
      continue;
    }
    btBroadphasePair& pair = pairs_[order[i].index];
    if (callback->processOverlap(pair))
      removeOverlappingPair(pair.m_pProxy0, pair.m_pProxy1, dispatcher);
    else
      ++i;
  }
}

btBroadphasePair* PairCache::findPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) {
  if (proxy0->m_uniqueId > proxy1->m_uniqueId) std::swap(proxy0, proxy1);
  const int index = find_index(key_of(proxy0, proxy1));
  return index == kNone ? nullptr : &pairs_[index];
}

void PairCache::sortOverlappingPairs(btDispatcher* dispatcher) {
  btBroadphasePairArray sorted;
  sorted.reserve(pairs_.size());
  for (int i = 0; i < pairs_.size(); ++i) sorted.push_back(pairs_[i]);
  for (int i = 0; i < sorted.size(); ++i)
    removeOverlappingPair(sorted[i].m_pProxy0, sorted[i].m_pProxy1, dispatcher);
  sorted.quickSort(btBroadphasePairSortPredicate());
  for (int i = 0; i < sorted.size(); ++i) addOverlappingPair(sorted[i].m_pProxy0, sorted[i].m_pProxy1);
}

std::size_t PairCache::longest_chain() const {
  std::size_t longest = 0;
  for (int first : head_) {
    std::size_t length = 0;
    for (int i = first; i != kNone; i = next_[static_cast<std::size_t>(i)]) ++length;
    longest = std::max(longest, length);
  }
  return longest;
}

}  // namespace soda
