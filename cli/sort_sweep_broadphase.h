// A small broadphase for `soda bench broadphase` (broadphase_replay.h): sort
// and sweep on one axis, I-COLLIDE's sorted interval list kept by insertion
// sort (boxes move little between steps, so the sort is near linear), the
// pairs found again every step by a sweep along that axis and an exact test
// on the other two.
//
// Its pairs are exact (closed boxes, no margin): a pair is in the cache
// after calculateOverlappingPairs exactly when the two boxes given to
// createProxy / setAabb overlap and the cache's filter accepts it. A pair
// found again keeps its cache entry (and with it, in a world, its
// algorithm and manifold); one not found is removed.
//
// Not a general broadphase: rayTest and aabbTest test every proxy.
// Thread safety: none.
#pragma once

#include <cstdint>
#include <vector>

#include <btBulletDynamicsCommon.h>

namespace soda::cli {

class SortSweepBroadphase final : public btBroadphaseInterface {
 public:
  /// Sweeps along `axis` (0, 1 or 2); pairs go to `pairs` (not owned,
  /// must outlive this).
  SortSweepBroadphase(btOverlappingPairCache* pairs, int axis);
  ~SortSweepBroadphase() override;

  btBroadphaseProxy* createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int shapeType, void* userPtr,
                                 int collisionFilterGroup, int collisionFilterMask, btDispatcher* dispatcher) override;
  /// Removes the proxy's pairs (the cache's removeOverlappingPairsContainingProxy)
  /// and frees it.
  void destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override;
  void setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
               btDispatcher* dispatcher) override;
  void getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const override;
  void rayTest(const btVector3& rayFrom, const btVector3& rayTo, btBroadphaseRayCallback& rayCallback,
               const btVector3& aabbMin, const btVector3& aabbMax) override;
  void aabbTest(const btVector3& aabbMin, const btVector3& aabbMax, btBroadphaseAabbCallback& callback) override;
  /// Sorts, sweeps, adds the pairs found, removes the others.
  void calculateOverlappingPairs(btDispatcher* dispatcher) override;
  btOverlappingPairCache* getOverlappingPairCache() override { return pairs_; }
  const btOverlappingPairCache* getOverlappingPairCache() const override { return pairs_; }
  void getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const override;
  void printStats() override {}

 private:
  void sort();

  btOverlappingPairCache* pairs_;
  int axis_;
  std::vector<btBroadphaseProxy*> order_;  // by m_aabbMin[axis_]: a sorted prefix, then the new ones
  std::size_t sorted_ = 0;                 // length of the sorted prefix
  std::size_t dead_ = 0;                   // destroyed proxies still in order_ (null)
  int next_id_ = 0;
  int stamp_ = 0;                          // this sweep's mark on the pairs it found
};

}  // namespace soda::cli
