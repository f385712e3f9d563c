// Internal: the island graph of one step and its canonical order, shared by
// the canonical world (canonical_dynamics_world.h) and the territory world
// (territory_world.h). Nodes are the dynamic bodies a world solves, numbered
// in ascending body id; edges are whatever makes two bodies one island — a
// manifold holding contact points today, a constraint tomorrow. Islands come
// from union-find (DESIGN.md §2: from contacts, never from broadphase pairs),
// and the things each island solves with (its manifolds, later its
// constraints) are listed per island in key order by IslandItems.
//
//   IslandBuilder islands;
//   islands.reset(n);                       // nodes 0 .. n-1, ascending id
//   for (each manifold with points) islands.join(node_of(a), node_of(b));
//   islands.finish();                       // islands by smallest node
//   IslandItems<btPersistentManifold*> manifolds;
//   for (each manifold) manifolds.add(islands.island_of(node), id0, id1, m);
//   manifolds.finish(islands.island_count());
//
// Invariants:
//  1. an island is a connected component of the nodes under the edges
//     joined; an edge with an end outside the graph (kNoNode: a static body,
//     a body another world solves) joins nothing;
//  2. islands are numbered by their smallest node, ascending: the numbering
//     depends on which nodes each island holds, never on the order of joins;
//  3. island k's nodes are listed ascending (nodes(k), a slice of order());
//  4. items are grouped by island, ascending, and by key inside an island;
//     items with equal keys keep no defined order among themselves
//     (first_duplicate() finds them, for callers whose keys must be unique).
//
// Thread safety: none; one builder per world, used by its stepping thread.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "soda/worlds/body_state.h"
#include "soda/worlds/disjoint_sets.h"

namespace soda {

class IslandBuilder {
 public:
  static constexpr int kNoNode = -1;

  /// Starts a step's graph over `node_count` nodes, each its own island.
  void reset(int node_count);
  /// An edge between nodes `a` and `b` (either may be kNoNode: no join).
  void join(int a, int b);
  /// After the last join: numbers the islands (invariant 2) and lists each
  /// one's nodes (invariant 3).
  void finish();

  int node_count() const { return sets_.size(); }
  int island_count() const { return static_cast<int>(begin_.size()) - 1; }
  /// The island of a node (finish() first).
  int island_of(int node) const { return island_of_[static_cast<std::size_t>(node)]; }
  /// Island k's nodes are order()[begin(k) .. begin(k + 1)).
  int begin(int island) const { return begin_[static_cast<std::size_t>(island)]; }
  int size(int island) const { return begin(island + 1) - begin(island); }
  const std::vector<int>& order() const { return order_; }

 private:
  DisjointSets sets_;           // a root is its island's smallest node
  std::vector<int> island_of_;  // per node
  std::vector<int> begin_{0};   // CSR offsets into order_, island_count() + 1
  std::vector<int> order_;      // nodes by island, ascending inside each
};

/// What islands solve with (manifolds, constraints), grouped by island and
/// ordered by key inside each (invariant 4). `values(k)` is contiguous, as
/// Bullet's solveGroup takes it.
template <class T, class Key = std::pair<BodyId, BodyId>>
class IslandItems {
 public:
  struct Item {
    int island;
    Key key;
    T value;
  };

  void clear() { items_.clear(), values_.clear(), begin_.assign(1, 0); }
  void add(int island, const Key& key, T value) { items_.push_back(Item{island, key, value}); }
  /// After the last add: sorts and lays the items out per island, for
  /// islands 0 .. island_count - 1 (every item's island must be one).
  void finish(int island_count) {
    std::sort(items_.begin(), items_.end(), [](const Item& x, const Item& y) {
      if (x.island != y.island) return x.island < y.island;
      return x.key < y.key;
    });
    values_.resize(items_.size());
    begin_.assign(static_cast<std::size_t>(island_count) + 1, 0);
    for (std::size_t i = 0; i < items_.size(); ++i) {
      values_[i] = items_[i].value;
      ++begin_[static_cast<std::size_t>(items_[i].island) + 1];
    }
    for (std::size_t k = 0; k + 1 < begin_.size(); ++k) begin_[k + 1] += begin_[k];
  }
  /// Index of the first item whose island and key equal the one before it,
  /// or -1.
  std::ptrdiff_t first_duplicate() const {
    for (std::size_t i = 1; i < items_.size(); ++i)
      if (items_[i].island == items_[i - 1].island && items_[i].key == items_[i - 1].key)
        return static_cast<std::ptrdiff_t>(i);
    return -1;
  }

  std::size_t size() const { return items_.size(); }
  const Item& operator[](std::size_t i) const { return items_[i]; }
  /// Island k's items are [begin(k), begin(k + 1)).
  int begin(int island) const { return begin_[static_cast<std::size_t>(island)]; }
  int count(int island) const { return begin(island + 1) - begin(island); }
  /// Island k's values, contiguous (null when it has none).
  T* values(int island) {
    return count(island) ? values_.data() + begin(island) : nullptr;
  }
  const std::vector<T>& values() const { return values_; }
  /// Every island's values, island after island (begin(k) is island k's).
  T* data() { return values_.data(); }

 private:
  std::vector<Item> items_;
  std::vector<T> values_;
  std::vector<int> begin_{0};
};

}  // namespace soda
