#include "sort_sweep_broadphase.h"

#include <algorithm>

namespace soda::cli {
namespace {

// A proxy destroyed stays in the order until the next sort drops and frees it.
struct SweepProxy : btBroadphaseProxy {
  using btBroadphaseProxy::btBroadphaseProxy;
  bool dead = false;
};

bool dead(const btBroadphaseProxy* p) { return static_cast<const SweepProxy*>(p)->dead; }

// Closed intervals on the axes other than `axis`.
bool overlap_off_axis(const btBroadphaseProxy* a, const btBroadphaseProxy* b, int axis) {
  for (int k = 0; k < 3; ++k) {
    if (k == axis) continue;
    if (a->m_aabbMin[k] > b->m_aabbMax[k] || a->m_aabbMax[k] < b->m_aabbMin[k]) return false;
  }
  return true;
}

}  // namespace

SortSweepBroadphase::SortSweepBroadphase(btOverlappingPairCache* pairs, int axis) : pairs_(pairs), axis_(axis) {}

SortSweepBroadphase::~SortSweepBroadphase() {
  for (btBroadphaseProxy* p : order_) delete static_cast<SweepProxy*>(p);
}

btBroadphaseProxy* SortSweepBroadphase::createProxy(const btVector3& aabbMin, const btVector3& aabbMax, int,
                                                    void* userPtr, int collisionFilterGroup,
                                                    int collisionFilterMask, btDispatcher*) {
  auto* p = new SweepProxy(aabbMin, aabbMax, userPtr, collisionFilterGroup, collisionFilterMask);
  p->m_uniqueId = ++next_id_;
  order_.push_back(p);
  return p;
}

void SortSweepBroadphase::destroyProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) {
  pairs_->removeOverlappingPairsContainingProxy(proxy, dispatcher);
  static_cast<SweepProxy*>(proxy)->dead = true;
  ++dead_;
}

void SortSweepBroadphase::setAabb(btBroadphaseProxy* proxy, const btVector3& aabbMin, const btVector3& aabbMax,
                                  btDispatcher*) {
  proxy->m_aabbMin = aabbMin;
  proxy->m_aabbMax = aabbMax;
}

void SortSweepBroadphase::getAabb(btBroadphaseProxy* proxy, btVector3& aabbMin, btVector3& aabbMax) const {
  aabbMin = proxy->m_aabbMin;
  aabbMax = proxy->m_aabbMax;
}

void SortSweepBroadphase::rayTest(const btVector3&, const btVector3&, btBroadphaseRayCallback& rayCallback,
                                  const btVector3&, const btVector3&) {
  for (btBroadphaseProxy* p : order_)
    if (!dead(p)) rayCallback.process(p);
}

void SortSweepBroadphase::aabbTest(const btVector3& aabbMin, const btVector3& aabbMax,
                                   btBroadphaseAabbCallback& callback) {
  for (btBroadphaseProxy* p : order_)
    if (!dead(p) && TestAabbAgainstAabb2(aabbMin, aabbMax, p->m_aabbMin, p->m_aabbMax)) callback.process(p);
}

void SortSweepBroadphase::getBroadphaseAabb(btVector3& aabbMin, btVector3& aabbMax) const {
  aabbMin.setValue(BT_LARGE_FLOAT, BT_LARGE_FLOAT, BT_LARGE_FLOAT);
  aabbMax = -aabbMin;
  for (const btBroadphaseProxy* p : order_) {
    if (dead(p)) continue;
    aabbMin.setMin(p->m_aabbMin);
    aabbMax.setMax(p->m_aabbMax);
  }
}

// The dead dropped, the sorted prefix kept sorted by insertion sort (the
// coherent part), the new proxies sorted and merged in.
void SortSweepBroadphase::sort() {
  const int axis = axis_;
  const auto before = [axis](const btBroadphaseProxy* a, const btBroadphaseProxy* b) {
    return a->m_aabbMin[axis] < b->m_aabbMin[axis];
  };
  if (dead_ > 0) {
    std::size_t kept = 0, kept_sorted = 0;
    for (std::size_t i = 0; i < order_.size(); ++i) {
      btBroadphaseProxy* p = order_[i];
      if (dead(p)) {
        delete static_cast<SweepProxy*>(p);
        continue;
      }
      order_[kept++] = p;
      if (i < sorted_) ++kept_sorted;
    }
    order_.resize(kept);
    sorted_ = kept_sorted;
    dead_ = 0;
  }
  for (std::size_t i = 1; i < sorted_; ++i) {
    btBroadphaseProxy* p = order_[i];
    std::size_t j = i;
    for (; j > 0 && before(p, order_[j - 1]); --j) order_[j] = order_[j - 1];
    order_[j] = p;
  }
  if (sorted_ < order_.size()) {
    const auto middle = order_.begin() + static_cast<std::ptrdiff_t>(sorted_);
    std::sort(middle, order_.end(), before);
    std::inplace_merge(order_.begin(), middle, order_.end(), before);
    sorted_ = order_.size();
  }
}

void SortSweepBroadphase::calculateOverlappingPairs(btDispatcher* dispatcher) {
  sort();
  ++stamp_;
  const std::size_t n = order_.size();
  for (std::size_t i = 0; i < n; ++i) {
    btBroadphaseProxy* a = order_[i];
    const btScalar end = a->m_aabbMax[axis_];
    for (std::size_t j = i + 1; j < n && order_[j]->m_aabbMin[axis_] <= end; ++j) {
      btBroadphaseProxy* b = order_[j];
      if (!overlap_off_axis(a, b, axis_)) continue;
      if (btBroadphasePair* pair = pairs_->addOverlappingPair(a, b)) pair->m_internalTmpValue = stamp_;
    }
  }
  btBroadphasePairArray& pairs = pairs_->getOverlappingPairArray();
  for (int i = 0; i < pairs.size();) {
    if (pairs[i].m_internalTmpValue == stamp_) {
      ++i;
    } else {
      pairs_->removeOverlappingPair(pairs[i].m_pProxy0, pairs[i].m_pProxy1, dispatcher);  // the last moves to i
    }
  }
}

}  // namespace soda::cli
