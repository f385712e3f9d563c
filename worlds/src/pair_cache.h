// Internal: the overlapping pair cache of every SODA world's dbvt
// broadphase (CanonicalWorld, TerritoryWorld). docs/memory.md, "Setup".
//
// Bullet's btHashedOverlappingPairCache keys a pair by
// `uid0 | (uid1 << 16)` in 32 bits, and compares a candidate by reading both
// of its proxies. Our proxies' unique ids are body ids + 1 (the canonical
// pair order), so above 65,536 ids the high bits of uid1 are lost, keys
// collide and every lookup walks a chain of N / 65,536 pairs (about 15 at
// 1,000,000 bodies) with three cache misses per link. This cache keys a
// pair by both unique ids in 64 bits and keeps the keys beside the chain
// links, so a lookup reads one bucket and, on average, about one key.
//
// What the rest of Bullet and SODA see is unchanged: the pair array evolves
// exactly as Bullet's (a new pair is appended; a removed one is replaced by
// the last pair, then the array shrinks by one; every walk over the pairs
// that removes some visits them in Bullet's order), so the order in which
// pairs are dispatched, and with it every result bit, is the same as with
// Bullet's cache. Only the lookup structure differs.
#pragma once

#include <cstdint>
#include <vector>

#include <btBulletDynamicsCommon.h>

namespace soda {

/// A btOverlappingPairCache with 64-bit pair keys, for btDbvtBroadphase's
/// constructor (the broadphase does not own it: declare it before the
/// broadphase so that it outlives it). Behaves as btHashedOverlappingPairCache
/// in every call: pairs ordered by proxy unique id (m_pProxy0 the lower),
/// the collision filter (or the filter callback) decides which pairs are
/// added, no deferred removal, the same pair array order after any sequence
/// of calls. Unique ids are compared as 32-bit unsigned values in the key
/// (any two distinct proxies give distinct keys). Not thread-safe: one world's
/// thread uses it. Throws std::bad_alloc when growing fails.
class PairCache final : public btOverlappingPairCache {
 public:
  PairCache();
  ~PairCache() override = default;
  PairCache(const PairCache&) = delete;
  PairCache& operator=(const PairCache&) = delete;

  /// Adds the pair (in unique-id order) unless the filter rejects it
  /// (returns null) or it exists (returns the existing pair). A new pair is
  /// appended to the pair array, without an algorithm. The pointer is valid
  /// until the next add or remove.
  btBroadphasePair* addOverlappingPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) override;
  /// Removes the pair if present: frees its algorithm through `dispatcher`
  /// (if not null), moves the last pair into its slot. Returns the pair's
  /// m_internalInfo1 (null if absent).
  void* removeOverlappingPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1,
                              btDispatcher* dispatcher) override;
  /// Off: removeOverlappingPairsContainingProxy and cleanProxyFromPairs do
  /// nothing, for a caller that has removed a batch of proxies' pairs in one
  /// sweep and then destroys the proxies (parking.h); on by default.
  void set_proxy_sweeps(bool on) { proxy_sweeps_ = on; }
  /// Removes every pair holding `proxy`: O(pairs).
  void removeOverlappingPairsContainingProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;

  btBroadphasePair* getOverlappingPairArrayPtr() override { return pairs_.size() ? &pairs_[0] : nullptr; }
  const btBroadphasePair* getOverlappingPairArrayPtr() const override {
    return pairs_.size() ? &pairs_[0] : nullptr;
  }
  btBroadphasePairArray& getOverlappingPairArray() override { return pairs_; }
  /// Frees the pair's algorithm through `dispatcher` (if both are not null);
  /// the pair stays.
  void cleanOverlappingPair(btBroadphasePair& pair, btDispatcher* dispatcher) override;
  int getNumOverlappingPairs() const override { return pairs_.size(); }
  bool needsBroadphaseCollision(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) const override;
  btOverlapFilterCallback* getOverlapFilterCallback() override { return filter_; }
  void setOverlapFilterCallback(btOverlapFilterCallback* callback) override { filter_ = callback; }
  /// Frees the algorithm of every pair holding `proxy`: O(pairs).
  void cleanProxyFromPairs(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;
  /// Calls `callback` on every pair in array order; a pair for which it
  /// returns true is removed (the last pair moves into its slot and is
  /// visited next).
  void processAllOverlappingPairs(btOverlapCallback* callback, btDispatcher* dispatcher) override;
  /// As above; with dispatch_info.m_deterministicOverlappingPairs, in
  /// Bullet's sorted order (SODA's worlds do not set it).
  void processAllOverlappingPairs(btOverlapCallback* callback, btDispatcher* dispatcher,
                                  const btDispatcherInfo& dispatch_info) override;
  /// The pair of the two proxies (either order), or null.
  btBroadphasePair* findPair(btBroadphaseProxy* proxy0, btBroadphaseProxy* proxy1) override;
  bool hasDeferredRemoval() override { return false; }
  void setInternalGhostPairCallback(btOverlappingPairCallback* callback) override { ghost_ = callback; }
  /// Removes every pair (freeing algorithms) and adds them back sorted by
  /// btBroadphasePairSortPredicate, as Bullet's cache does.
  void sortOverlappingPairs(btDispatcher* dispatcher) override;

  /// Number of hash buckets (a power of two, at least the pair count).
  std::size_t bucket_count() const { return head_.size(); }
  /// Length of the longest bucket chain: O(pairs), for tests.
  std::size_t longest_chain() const;

 private:
  static constexpr int kNone = -1;
  static std::uint64_t key_of(const btBroadphaseProxy* low, const btBroadphaseProxy* high);
  std::size_t bucket_of(std::uint64_t key) const;
  int find_index(std::uint64_t key) const;
  void grow_buckets();

  btBroadphasePairArray pairs_;
  std::vector<std::uint64_t> keys_;  // per pair: its key
  std::vector<int> next_;            // per pair: the next pair in its bucket, or kNone
  std::vector<int> head_;            // per bucket: its first pair, or kNone
  btOverlapFilterCallback* filter_ = nullptr;
  btOverlappingPairCallback* ghost_ = nullptr;
  bool proxy_sweeps_ = true;
};

}  // namespace soda
