// worlds/ — disjoint sets (union-find) over nodes 0 .. size() - 1, the one
// union-find of SODA: the island builder (islands of one world's step) and
// the island merger (fragments of a border island across worlds) use it.
// find() halves paths; which root a union keeps is the caller's rule
// (attach): the island builder keeps the smallest node, so islands are
// numbered by their smallest node; the merger keeps the larger component.
//
//   DisjointSets sets;
//   sets.reset(4);                                   // {0} {1} {2} {3}
//   const int a = sets.find(1), b = sets.find(3);
//   if (a != b) sets.attach(std::max(a, b), std::min(a, b));  // {0} {1, 3} {2}
//
// Thread safety: none (find() compresses paths).
#pragma once

#include <cstddef>
#include <numeric>
#include <vector>

namespace soda {

class DisjointSets {
 public:
  /// `n` nodes, each a set of its own.
  void reset(int n) {
    parent_.resize(static_cast<std::size_t>(n));
    std::iota(parent_.begin(), parent_.end(), 0);
  }
  /// A new node, a set of its own; returns it (the old size()).
  int add() {
    parent_.push_back(size());
    return parent_.back();
  }
  int size() const { return static_cast<int>(parent_.size()); }
  /// The root of `i`'s set.
  int find(int i) {
    while (parent_[at(i)] != i) {
      parent_[at(i)] = parent_[at(parent_[at(i)])];
      i = parent_[at(i)];
    }
    return i;
  }
  /// Joins two sets by their roots: `child_root` goes under `parent_root`.
  void attach(int child_root, int parent_root) { parent_[at(child_root)] = parent_root; }

 private:
  static std::size_t at(int i) { return static_cast<std::size_t>(i); }
  std::vector<int> parent_;
};

}  // namespace soda
