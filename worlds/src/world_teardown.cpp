#include "world_teardown.h"

namespace soda {

void release_all_pairs(btBroadphaseInterface& broadphase, btDispatcher& dispatcher) {
  btOverlappingPairCache* cache = broadphase.getOverlappingPairCache();
  btBroadphasePairArray& pairs = cache->getOverlappingPairArray();
  // Always the last pair: the hashed cache then pops it without moving
  // another pair into its slot; removal frees the algorithm (and through
  // the dispatcher, its manifold: an O(1) swap-and-pop by index).
  while (pairs.size() > 0) {
    btBroadphasePair& last = pairs[pairs.size() - 1];
    cache->removeOverlappingPair(last.m_pProxy0, last.m_pProxy1, &dispatcher);
  }
}

}  // namespace soda
