// IslandBuilder (island_builder.h): disjoint sets (disjoint_sets.h), the
// root of a set always its smallest node, so numbering the roots in node order
// numbers the islands by their smallest node.
#include "island_builder.h"

#include <numeric>
#include <stdexcept>

namespace soda {

void IslandBuilder::reset(int node_count) {
  if (node_count < 0) throw std::invalid_argument("IslandBuilder: a negative node count");
  sets_.reset(node_count);
}

void IslandBuilder::join(int a, int b) {
  if (a == kNoNode || b == kNoNode) return;
  const int ra = sets_.find(a), rb = sets_.find(b);
  if (ra != rb) sets_.attach(std::max(ra, rb), std::min(ra, rb));  // root = smallest node
}

void IslandBuilder::finish() {
  const int n = node_count();
  island_of_.resize(static_cast<std::size_t>(n));
  int count = 0;
  for (int i = 0; i < n; ++i) {
    const int r = sets_.find(i);
    island_of_[static_cast<std::size_t>(i)] = r == i ? count++ : island_of_[static_cast<std::size_t>(r)];
  }
  begin_.assign(static_cast<std::size_t>(count) + 1, 0);
  for (int i = 0; i < n; ++i) ++begin_[static_cast<std::size_t>(island_of_[static_cast<std::size_t>(i)]) + 1];
  for (int k = 0; k < count; ++k) begin_[static_cast<std::size_t>(k) + 1] += begin_[static_cast<std::size_t>(k)];
  order_.resize(static_cast<std::size_t>(n));
  std::vector<int> cursor(begin_.begin(), begin_.end() - 1);
  for (int i = 0; i < n; ++i)
    order_[static_cast<std::size_t>(cursor[static_cast<std::size_t>(island_of_[static_cast<std::size_t>(i)])]++)] = i;
}

}  // namespace soda
