#include "broadphase_replay.h"

#include <BulletCollision/BroadphaseCollision/btAxisSweep3.h>
#include <BulletCollision/BroadphaseCollision/btDbvtBroadphase.h>

#include <algorithm>
#include <chrono>
#include <cstddef>

#include "canonical_dynamics_world.h"
#include "soda/scene/fnv1a.h"
#include "sort_sweep_broadphase.h"
#include "soda/worlds/stock_world.h"

namespace soda::cli {
namespace {

// The SAP's world box: every recorded box, plus this on every side (metres),
// so that no box touches the quantisation's clamp.
constexpr btScalar kWorldMargin = 10;
double wall_seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

RecordedBox box_of(std::uint32_t body, const btBroadphaseProxy& proxy) {
  RecordedBox b;
  b.body = body;
  for (int k = 0; k < 3; ++k) {
    b.min[k] = proxy.m_aabbMin[k];
    b.max[k] = proxy.m_aabbMax[k];
  }
  return b;
}

void grow(btVector3& lo, btVector3& hi, const RecordedBox& b) {
  lo.setMin(btVector3(b.min[0], b.min[1], b.min[2]));
  hi.setMax(btVector3(b.max[0], b.max[1], b.max[2]));
}

// The axis of the largest variance of the awake boxes' centres, all steps.
int widest_spread_axis(const Recording& rec) {
  double sum[3]{}, sum2[3]{}, count = 0;
  for (const std::vector<RecordedBox>& awake : rec.awake)
    for (const RecordedBox& b : awake) {
      for (int k = 0; k < 3; ++k) {
        const double c = 0.5 * (double(b.min[k]) + double(b.max[k]));
        sum[k] += c;
        sum2[k] += c * c;
      }
      ++count;
    }
  int widest = 0;
  double most = -1;
  for (int k = 0; k < 3 && count > 0; ++k) {
    const double variance = sum2[k] / count - (sum[k] / count) * (sum[k] / count);
    if (variance > most) most = variance, widest = k;
  }
  return widest;
}

// Closed boxes, as Bullet's TestAabbAgainstAabb2.
bool boxes_overlap(const RecordedBox& a, const RecordedBox& b) {
  for (int k = 0; k < 3; ++k)
    if (a.min[k] > b.max[k] || a.max[k] < b.min[k]) return false;
  return true;
}

const RecordedBody& body_of(const btBroadphaseProxy* proxy) {
  return *static_cast<const RecordedBody*>(proxy->m_clientObject);
}

// Group and mask both ways, never two statics: the worlds' BodyFilter on
// the scenes measured (no sensors, no kinematic bodies).
bool may_pair(const RecordedBody& a, const RecordedBody& b) {
  return (a.group & b.mask) != 0 && (b.group & a.mask) != 0 && !(a.is_static && b.is_static);
}

// The pair as the worlds order it: the smaller body id in the high half.
std::uint64_t pair_key(const RecordedBody& a, const RecordedBody& b) {
  const auto ida = static_cast<std::uint32_t>(a.id), idb = static_cast<std::uint32_t>(b.id);
  return (std::uint64_t{std::min(ida, idb)} << 32) | std::max(ida, idb);
}

struct ReplayFilter final : btOverlapFilterCallback {
  bool needBroadphaseCollision(btBroadphaseProxy* a, btBroadphaseProxy* b) const override {
    return may_pair(body_of(a), body_of(b));
  }
};

// Bullet's hashed cache whose per-proxy sweep can be turned off while a
// batch of proxies whose pairs are already gone is destroyed (as the
// worlds' PairCache::set_proxy_sweeps, for parking).
class ReplayPairCache final : public btHashedOverlappingPairCache {
 public:
  void removeOverlappingPairsContainingProxy(btBroadphaseProxy* proxy, btDispatcher* dispatcher) override {
    if (sweeps) btHashedOverlappingPairCache::removeOverlappingPairsContainingProxy(proxy, dispatcher);
  }
  bool sweeps = true;
};

// One broadphase with its pair cache, fed a Recording step by step.
class Lane {
 public:
  Lane(const Recording& rec, const BroadphaseKind& kind);
  ~Lane();
  Lane(const Lane&) = delete;
  Lane& operator=(const Lane&) = delete;

  /// Step `s`'s broadphase work: what is timed.
  void step(std::size_t s);
  /// The step's pairs, those whose `boxes` overlap, into `out`.
  void exact_pairs(const std::vector<RecordedBox>& boxes, ReplayResult& out) const;

 private:
  void create(const RecordedBox& box);
  void take_out(const std::vector<std::uint32_t>& leaving);
  void remove_stale_pairs();
  std::uint32_t index_of(const btBroadphaseProxy* proxy) const {
    return static_cast<std::uint32_t>(&body_of(proxy) - rec_.bodies.data());
  }

  const Recording& rec_;
  BroadphaseKind kind_;
  ReplayFilter filter_;
  std::unique_ptr<ReplayPairCache> pairs_ = std::make_unique<ReplayPairCache>();
  std::unique_ptr<btBroadphaseInterface> broadphase_;
  btDbvtBroadphase* dbvt_ = nullptr;           // broadphase_, when a DBVT
  std::vector<btBroadphaseProxy*> proxies_;    // per body; null while out
  std::vector<char> leaving_;                  // per body: in this step's leaving batch
};

Lane::Lane(const Recording& rec, const BroadphaseKind& kind)
    : rec_(rec), kind_(kind), proxies_(rec.bodies.size(), nullptr), leaving_(rec.bodies.size(), 0) {
  pairs_->setOverlapFilterCallback(&filter_);
  if (kind.structure == BroadphaseKind::Structure::Dbvt) {
    auto dbvt = std::make_unique<btDbvtBroadphase>(pairs_.get());
    dbvt_ = dbvt.get();
    broadphase_ = std::move(dbvt);
  } else if (kind.structure == BroadphaseKind::Structure::SortSweep) {
    broadphase_ = std::make_unique<SortSweepBroadphase>(pairs_.get(), rec.sweep_axis);
  } else {
    // Without the raycast accelerator (a second, DBVT broadphase mirroring
    // every proxy): the sweep and prune alone.
    broadphase_ = std::make_unique<bt32BitAxisSweep3>(rec.world_min, rec.world_max,
                                                      static_cast<unsigned>(rec.bodies.size() + 1), pairs_.get(),
                                                      true);
  }
  for (const RecordedBox& box : rec.statics) create(box);
}

Lane::~Lane() {
  pairs_->sweeps = false;  // the pairs go with the cache
  if (dbvt_)  // its proxies are allocated one by one; the SAP's live in its handle array
    for (btBroadphaseProxy*& p : proxies_)
      if (p) broadphase_->destroyProxy(p, nullptr);
  broadphase_.reset();
}

void Lane::create(const RecordedBox& box) {
  const RecordedBody& body = rec_.bodies[box.body];
  const btVector3 lo(box.min[0], box.min[1], box.min[2]), hi(box.max[0], box.max[1], box.max[2]);
  if (kind_.soda_rules) dbvt_->m_gid = body.id;  // proxy unique id = body id + 1: the canonical pair order
  proxies_[box.body] = broadphase_->createProxy(lo, hi, BOX_SHAPE_PROXYTYPE, const_cast<RecordedBody*>(&body),
                                                body.group, body.mask, nullptr);
  if (kind_.soda_rules) rebalance_after_insertion(*dbvt_);  // as the worlds' add_body_with_canonical_proxy
}

// As parking takes a batch of bodies out: their pairs in one sweep, then
// their proxies without a sweep each.
void Lane::take_out(const std::vector<std::uint32_t>& leaving) {
  for (std::uint32_t b : leaving) leaving_[b] = 1;
  btBroadphasePairArray& pairs = pairs_->getOverlappingPairArray();
  for (int i = 0; i < pairs.size();) {
    btBroadphasePair& pair = pairs[i];
    if (leaving_[index_of(pair.m_pProxy0)] || leaving_[index_of(pair.m_pProxy1)]) {
      pairs_->removeOverlappingPair(pair.m_pProxy0, pair.m_pProxy1, nullptr);  // the last pair moves to i
    } else {
      ++i;
    }
  }
  pairs_->sweeps = false;
  for (std::uint32_t b : leaving) {
    broadphase_->destroyProxy(proxies_[b], nullptr);
    proxies_[b] = nullptr;
    leaving_[b] = 0;
  }
  pairs_->sweeps = true;
}

// The worlds' rule: every pair whose leaf volumes no longer overlap, every
// step (pairs_ is the tree's pair cache).
void Lane::remove_stale_pairs() { soda::remove_stale_pairs(*dbvt_, nullptr); }

void Lane::step(std::size_t s) {
  if (!rec_.leaving[s].empty()) take_out(rec_.leaving[s]);
  for (const RecordedBox& box : rec_.awake[s]) {
    btBroadphaseProxy* p = proxies_[box.body];
    if (!p) {
      create(box);
    } else {
      broadphase_->setAabb(p, btVector3(box.min[0], box.min[1], box.min[2]),
                           btVector3(box.max[0], box.max[1], box.max[2]), nullptr);
    }
  }
  broadphase_->calculateOverlappingPairs(nullptr);
  if (kind_.soda_rules) remove_stale_pairs();
}

void Lane::exact_pairs(const std::vector<RecordedBox>& boxes, ReplayResult& out) const {
  const btBroadphasePairArray& pairs = pairs_->getOverlappingPairArray();
  std::vector<std::uint64_t> exact;
  exact.reserve(static_cast<std::size_t>(pairs.size()));
  for (int i = 0; i < pairs.size(); ++i) {
    const std::uint32_t a = index_of(pairs[i].m_pProxy0), b = index_of(pairs[i].m_pProxy1);
    if (!boxes_overlap(boxes[a], boxes[b])) continue;
    exact.push_back(pair_key(rec_.bodies[a], rec_.bodies[b]));
  }
  std::sort(exact.begin(), exact.end());
  out.raw_pairs.push_back(static_cast<std::size_t>(pairs.size()));
  out.exact_pairs.push_back(exact.size());
  out.exact_hash.push_back(fnv1a(exact.data(), exact.size() * sizeof(std::uint64_t)));
}

}  // namespace

Recording record_scene(const Scene& scene, int steps) {
  StockWorld world(scene);
  const btCollisionObjectArray& objects = world.bullet().getCollisionObjectArray();
  Recording rec;
  rec.world_min = btVector3(BT_LARGE_FLOAT, BT_LARGE_FLOAT, BT_LARGE_FLOAT);
  rec.world_max = -rec.world_min;
  const auto n = static_cast<std::uint32_t>(objects.size());
  for (std::uint32_t i = 0; i < n; ++i) {
    const btCollisionObject& o = *objects[static_cast<int>(i)];
    const btBroadphaseProxy& p = *o.getBroadphaseHandle();
    rec.bodies.push_back({o.getUserIndex(), o.isStaticObject(), p.m_collisionFilterGroup, p.m_collisionFilterMask});
    if (!o.isStaticObject()) continue;
    rec.statics.push_back(box_of(i, p));
    grow(rec.world_min, rec.world_max, rec.statics.back());
  }
  std::vector<char> was_awake(n, 0);
  for (int s = 0; s < steps; ++s) {
    const auto t0 = std::chrono::steady_clock::now();
    world.step();
    rec.stepping_seconds += wall_seconds_since(t0);
    std::vector<RecordedBox>& awake = rec.awake.emplace_back();
    std::vector<std::uint32_t>& arriving = rec.arriving.emplace_back();
    std::vector<std::uint32_t>& leaving = rec.leaving.emplace_back();
    for (std::uint32_t i = 0; i < n; ++i) {
      const btCollisionObject& o = *objects[static_cast<int>(i)];
      if (o.isStaticObject()) continue;
      const bool now = o.isActive();
      if (now) {
        awake.push_back(box_of(i, *o.getBroadphaseHandle()));
        grow(rec.world_min, rec.world_max, awake.back());
        if (!was_awake[i]) arriving.push_back(i);
      } else if (was_awake[i]) {
        leaving.push_back(i);
      }
      was_awake[i] = now;
    }
  }
  rec.sweep_axis = widest_spread_axis(rec);
  const btVector3 margin(kWorldMargin, kWorldMargin, kWorldMargin);
  rec.world_min -= margin;
  rec.world_max += margin;
  return rec;
}

std::vector<BroadphaseKind> broadphase_kinds() {
  return {{"dbvt", "btDbvtBroadphase as the worlds use it: proxy ids = body ids + 1, every stale pair removed "
                   "each step, top-down rebuild at 4096, 8192, ... leaves",
           BroadphaseKind::Structure::Dbvt, true},
          {"dbvt-stock", "btDbvtBroadphase with Bullet's defaults (a tenth of stale pairs checked per step)",
           BroadphaseKind::Structure::Dbvt, false},
          {"sap", "bt32BitAxisSweep3 (incremental sweep and prune, insertion sort on 3 axes), no raycast "
                  "accelerator, world box = every recorded box + 10 m",
           BroadphaseKind::Structure::AxisSweep, false},
          {"sort-sweep", "SortSweepBroadphase: one axis (the awake boxes' widest spread) kept sorted by insertion "
                         "sort, swept every step, exact pairs",
           BroadphaseKind::Structure::SortSweep, false}};
}

ReplayResult replay(const Recording& rec, const BroadphaseKind& kind, bool check) {
  Lane lane(rec, kind);
  ReplayResult r;
  std::vector<RecordedBox> boxes;
  if (check) {
    boxes.resize(rec.bodies.size());
    for (const RecordedBox& b : rec.statics) boxes[b.body] = b;
  }
  r.step_seconds.reserve(rec.awake.size());
  for (std::size_t s = 0; s < rec.awake.size(); ++s) {
    const auto t0 = std::chrono::steady_clock::now();
    lane.step(s);
    r.step_seconds.push_back(wall_seconds_since(t0));
    if (!check) continue;
    for (const RecordedBox& b : rec.awake[s]) boxes[b.body] = b;
    lane.exact_pairs(boxes, r);
  }
  return r;
}

std::vector<std::uint64_t> brute_force_hashes(const Recording& rec) {
  std::vector<std::uint64_t> hashes;
  std::vector<std::uint64_t> exact;
  for (const std::vector<RecordedBox>& awake : rec.awake) {
    std::vector<RecordedBox> in = rec.statics;
    in.insert(in.end(), awake.begin(), awake.end());
    exact.clear();
    for (std::size_t i = 0; i < in.size(); ++i)
      for (std::size_t k = i + 1; k < in.size(); ++k) {
        const RecordedBody &a = rec.bodies[in[i].body], &b = rec.bodies[in[k].body];
        if (may_pair(a, b) && boxes_overlap(in[i], in[k])) exact.push_back(pair_key(a, b));
      }
    std::sort(exact.begin(), exact.end());
    hashes.push_back(fnv1a(exact.data(), exact.size() * sizeof(std::uint64_t)));
  }
  return hashes;
}

}  // namespace soda::cli
