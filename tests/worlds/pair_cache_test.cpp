// PairCache (worlds/src/pair_cache.h): the pair array evolves exactly as in
// Bullet's btHashedOverlappingPairCache under any sequence of calls (so the
// dispatch order, and every result, is unchanged), and pairs of proxies whose
// unique ids lie beyond 65,536 get keys of their own (short bucket chains).
#include <cstdint>
#include <memory>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "pair_cache.h"

namespace soda {
namespace {

// `count` proxies with unique ids first_id, first_id + 1, ...
std::vector<std::unique_ptr<btBroadphaseProxy>> make_proxies(int count, int first_id) {
  std::vector<std::unique_ptr<btBroadphaseProxy>> proxies;
  proxies.reserve(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    auto p = std::make_unique<btBroadphaseProxy>(btVector3(0, 0, 0), btVector3(1, 1, 1), nullptr,
                                                 btBroadphaseProxy::DefaultFilter,
                                                 btBroadphaseProxy::AllFilter);
    p->m_uniqueId = first_id + i;
    proxies.push_back(std::move(p));
  }
  return proxies;
}

void expect_same_array(btOverlappingPairCache& ours, btOverlappingPairCache& bullet, int op) {
  const btBroadphasePairArray& a = ours.getOverlappingPairArray();
  const btBroadphasePairArray& b = bullet.getOverlappingPairArray();
  ASSERT_EQ(a.size(), b.size()) << "after operation " << op;
  for (int i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].m_pProxy0, b[i].m_pProxy0) << "slot " << i << " after operation " << op;
    ASSERT_EQ(a[i].m_pProxy1, b[i].m_pProxy1) << "slot " << i << " after operation " << op;
  }
}

// Removes the pairs whose ids sum to an odd number.
struct RemoveOdd final : btOverlapCallback {
  bool processOverlap(btBroadphasePair& pair) override {
    return ((pair.m_pProxy0->m_uniqueId + pair.m_pProxy1->m_uniqueId) & 1) != 0;
  }
};

// Random adds (also repeated ones), removals (also of absent pairs),
// removal of every pair of a proxy and walks that remove some pairs, on
// ids around and above 65,536: the pair array is Bullet's, slot by slot.
TEST(PairCache, PairArrayEvolvesAsBulletsCache) {
  auto proxies = make_proxies(400, 65'400);  // ids 65,400 .. 65,799
  PairCache ours;
  btHashedOverlappingPairCache bullet;
  std::mt19937 rng(14);
  std::uniform_int_distribution<int> pick(0, 399), near(-20, 20), what(0, 99);
  for (int op = 0; op < 40'000; ++op) {
    const int i = pick(rng);
    const int j = std::clamp(i + near(rng), 0, 399);
    if (i == j) continue;
    btBroadphaseProxy* a = proxies[static_cast<std::size_t>(i)].get();
    btBroadphaseProxy* b = proxies[static_cast<std::size_t>(j)].get();
    const int w = what(rng);
    if (w < 60) {
      btBroadphasePair* x = ours.addOverlappingPair(a, b);
      btBroadphasePair* y = bullet.addOverlappingPair(a, b);
      ASSERT_TRUE(x && y);
      EXPECT_EQ(x - ours.getOverlappingPairArrayPtr(), y - bullet.getOverlappingPairArrayPtr());
    } else if (w < 95) {
      EXPECT_EQ(ours.removeOverlappingPair(a, b, nullptr), bullet.removeOverlappingPair(a, b, nullptr));
    } else if (w < 98) {
      ours.removeOverlappingPairsContainingProxy(a, nullptr);
      bullet.removeOverlappingPairsContainingProxy(a, nullptr);
    } else {
      RemoveOdd remove_odd;
      ours.processAllOverlappingPairs(&remove_odd, nullptr);
      bullet.processAllOverlappingPairs(&remove_odd, nullptr);
    }
    expect_same_array(ours, bullet, op);
    if (HasFatalFailure()) return;
  }
  ours.sortOverlappingPairs(nullptr);
  static_cast<btOverlappingPairCache&>(bullet).sortOverlappingPairs(nullptr);  // private in the class
  expect_same_array(ours, bullet, -1);
}

TEST(PairCache, FindsAddsAndRemovesPairsBeyond65536Ids) {
  // Ids 1, 2, 65,538 and 131,074: Bullet's 32-bit key uid0 | uid1 << 16 is
  // the same for (1, 2), (1, 65,538) and (1, 131,074).
  auto p = make_proxies(1, 1);
  auto q = make_proxies(1, 2);
  auto r = make_proxies(1, 65'538);
  auto s = make_proxies(1, 131'074);
  PairCache cache;
  btBroadphasePair* pq = cache.addOverlappingPair(q[0].get(), p[0].get());
  ASSERT_NE(pq, nullptr);
  EXPECT_EQ(pq->m_pProxy0, p[0].get());  // lower id first
  cache.addOverlappingPair(p[0].get(), r[0].get());
  cache.addOverlappingPair(s[0].get(), p[0].get());
  EXPECT_EQ(cache.getNumOverlappingPairs(), 3);
  EXPECT_EQ(cache.addOverlappingPair(r[0].get(), p[0].get()), cache.findPair(p[0].get(), r[0].get()));
  EXPECT_EQ(cache.getNumOverlappingPairs(), 3);  // an existing pair is not added again

  btBroadphasePair* pr = cache.findPair(r[0].get(), p[0].get());
  ASSERT_NE(pr, nullptr);
  EXPECT_EQ(pr->m_pProxy1, r[0].get());
  EXPECT_EQ(cache.findPair(q[0].get(), r[0].get()), nullptr);

  cache.removeOverlappingPair(p[0].get(), q[0].get(), nullptr);
  EXPECT_EQ(cache.findPair(p[0].get(), q[0].get()), nullptr);
  ASSERT_NE(cache.findPair(p[0].get(), r[0].get()), nullptr);
  ASSERT_NE(cache.findPair(p[0].get(), s[0].get()), nullptr);
  EXPECT_EQ(cache.findPair(p[0].get(), s[0].get())->m_pProxy1, s[0].get());
  EXPECT_EQ(cache.removeOverlappingPair(p[0].get(), q[0].get(), nullptr), nullptr);  // absent: no-op
  cache.removeOverlappingPairsContainingProxy(p[0].get(), nullptr);
  EXPECT_EQ(cache.getNumOverlappingPairs(), 0);
}

TEST(PairCache, RespectsTheCollisionFilter) {
  auto p = make_proxies(2, 1);
  p[1]->m_collisionFilterGroup = btBroadphaseProxy::StaticFilter;
  p[0]->m_collisionFilterMask = btBroadphaseProxy::AllFilter ^ btBroadphaseProxy::StaticFilter;
  PairCache cache;
  EXPECT_EQ(cache.addOverlappingPair(p[0].get(), p[1].get()), nullptr);
  EXPECT_EQ(cache.getNumOverlappingPairs(), 0);
}

// The pairs of neighbours in a 1,000,000-body pile (ids up to ~300,000 here:
// each body and the ones 1, 10 and 3,160 ids above it) spread over the
// buckets: no chain is long. With a key that keeps 16 bits of the higher
// id, as Bullet's, pairs 65,536 ids apart share a key.
TEST(PairCache, NeighbourPairsOfManyIdsGetShortChains) {
  constexpr int kBodies = 300'000;
  auto proxies = make_proxies(kBodies, 1);
  PairCache cache;
  for (int i = 0; i < kBodies; ++i)
    for (int d : {1, 10, 3'160})
      if (i + d < kBodies)
        cache.addOverlappingPair(proxies[static_cast<std::size_t>(i)].get(),
                                 proxies[static_cast<std::size_t>(i + d)].get());
  const int pairs = cache.getNumOverlappingPairs();
  EXPECT_EQ(pairs, 3 * kBodies - 1 - 10 - 3'160);
  EXPECT_GE(cache.bucket_count(), static_cast<std::size_t>(pairs));
  EXPECT_LE(cache.longest_chain(), 16u);
  for (int i = 0; i + 3'160 < kBodies; i += 997) {
    btBroadphasePair* pair = cache.findPair(proxies[static_cast<std::size_t>(i + 3'160)].get(),
                                            proxies[static_cast<std::size_t>(i)].get());
    ASSERT_NE(pair, nullptr);
    EXPECT_EQ(pair->m_pProxy0->m_uniqueId, i + 1);
    EXPECT_EQ(pair->m_pProxy1->m_uniqueId, i + 3'161);
  }
}

}  // namespace
}  // namespace soda
