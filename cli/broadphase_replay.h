// `soda bench broadphase` (cmd_broadphase.cpp): a scene's boxes recorded
// once from a stock Bullet world, then replayed into several broadphases,
// each timed on the broadphase's own work alone and checked against the
// others pair for pair (docs/results/broadphase.md).
//
// What a replay stands for: the broadphase of one territory with parking
// (docs/skip.md). Only awake bodies are in it; a body that falls asleep
// leaves it (as parking takes a settled island's bodies out) and one that
// wakes comes back. Statics are in it from the start and never move.
//
// Invariants the replay keeps:
//  1. every broadphase sees the same calls in the same order: per step, the
//     leaving bodies (one sweep over the pairs, then their proxies
//     destroyed, as parking does), then every awake body in body order
//     (created if it arrived, else setAabb), then calculateOverlappingPairs;
//  2. the recorded boxes are the stock world's broadphase boxes of that
//     step (Bullet's AABB with its contact threshold), bit for bit;
//  3. the pairs a broadphase reports are compared as body id pairs (the
//     smaller id first, sorted), after dropping those whose recorded boxes
//     do not overlap (closed boxes, as Bullet's TestAabbAgainstAabb2):
//     broadphases may report more (fattened or quantised boxes), never fewer.
//
// Thread safety: none; one thread records and replays.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <btBulletDynamicsCommon.h>

#include "soda/scene/scene.h"

namespace soda::cli {

/// One body's box in one step: Bullet's AABB, as btScalar triples.
struct RecordedBox {
  std::uint32_t body = 0;  // index into Recording::bodies
  btScalar min[3]{}, max[3]{};
};

/// What a broadphase needs to know of a body.
struct RecordedBody {
  int id = 0;  // the scene's body id (its Bullet user index)
  bool is_static = false;
  int group = 0, mask = 0;  // the proxy's filter, as the stock world set it
};

/// The scene's boxes, step by step.
struct Recording {
  std::vector<RecordedBody> bodies;             // scene order
  std::vector<RecordedBox> statics;             // once, before step 0
  std::vector<std::vector<RecordedBox>> awake;  // per step: awake bodies, body order
  std::vector<std::vector<std::uint32_t>> arriving;  // per step: awake now, not the step before
  std::vector<std::vector<std::uint32_t>> leaving;   // per step: awake the step before, not now
  btVector3 world_min, world_max;  // every recorded box fits inside, plus kWorldMargin
  double stepping_seconds = 0;     // the stock world's steps alone (wall)
  int sweep_axis = 0;  // the axis along which the awake boxes' centres spread most, over all steps
};

/// Steps `scene` in a StockWorld (Bullet's sleeping on) for `steps` steps
/// and records, after each, the broadphase box of every awake body.
Recording record_scene(const Scene& scene, int steps);

/// One broadphase under test.
struct BroadphaseKind {
  enum class Structure { Dbvt, AxisSweep, SortSweep };
  std::string name;
  std::string what;  // one line: the broadphase and its settings
  Structure structure = Structure::Dbvt;
  bool soda_rules = false;  // the worlds' DBVT use: canonical proxy ids, every stale pair removed each step
};

/// The kinds measured: "dbvt" (as the worlds use it, the baseline),
/// "dbvt-stock" (Bullet's defaults), "sap" (bt32BitAxisSweep3),
/// "sort-sweep" (SortSweepBroadphase on Recording::sweep_axis).
std::vector<BroadphaseKind> broadphase_kinds();

/// One broadphase's replay of a Recording: per step seconds, pair counts.
struct ReplayResult {
  std::vector<double> step_seconds;
  std::vector<std::size_t> raw_pairs;  // per step: the pair cache's pairs
  std::vector<std::size_t> exact_pairs;  // per step: those whose boxes overlap
  std::vector<std::uint64_t> exact_hash;  // per step: FNV-1a of the sorted exact pairs
};

/// Replays `rec` into a fresh broadphase of `kind`. With `check`, fills
/// raw_pairs, exact_pairs and exact_hash (untimed, after each step's timed
/// work); without, step_seconds only.
ReplayResult replay(const Recording& rec, const BroadphaseKind& kind, bool check);

/// Per step: FNV-1a of the sorted exact pairs found by testing every two
/// bodies in the broadphase (statics and awake bodies) under the same
/// filter, for a check that needs no broadphase. O(bodies^2) a step: for
/// small scenes.
std::vector<std::uint64_t> brute_force_hashes(const Recording& rec);

}  // namespace soda::cli
