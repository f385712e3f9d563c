// Contiguity and ownership repairs on a box of owners (partition_detail.h).
#include <algorithm>
#include <map>
#include <stdexcept>

#include "partition_detail.h"

namespace soda::detail {
namespace {

// 6-connected pieces of equal owners, discovered in box index order.
struct Pieces {
  std::vector<std::size_t> cells;  // grouped by piece, BFS order within a piece
  std::vector<std::size_t> start;  // piece p: cells[start[p] .. start[p + 1])
  std::vector<WorldId> owner;      // per piece
};

Pieces find_pieces(const CellBox& box, std::span<const WorldId> owners) {
  Pieces p;
  std::vector<char> seen(owners.size(), 0);
  for (std::size_t s = 0; s < owners.size(); ++s) {
    if (seen[s]) continue;
    const WorldId w = owners[s];
    p.start.push_back(p.cells.size());
    p.owner.push_back(w);
    seen[s] = 1;
    p.cells.push_back(s);
    for (std::size_t head = p.start.back(); head < p.cells.size(); ++head)
      for_each_face_neighbour(box, p.cells[head], [&](std::size_t n) {
        if (!seen[n] && owners[n] == w) {
          seen[n] = 1;
          p.cells.push_back(n);
        }
      });
  }
  p.start.push_back(p.cells.size());
  return p;
}

}  // namespace

void fill_unowned(const CellBox& box, std::vector<WorldId>& owners) {
  std::vector<std::size_t> frontier;
  for (std::size_t i = 0; i < owners.size(); ++i)
    if (owners[i] != kNoWorld) frontier.push_back(i);
  if (frontier.empty()) throw std::logic_error("fill_unowned: no owned cell to grow from");
  std::vector<char> queued(owners.size(), 0);
  while (!frontier.empty()) {
    std::vector<std::size_t> next;
    for (std::size_t i : frontier)
      for_each_face_neighbour(box, i, [&](std::size_t n) {
        if (owners[n] == kNoWorld && !queued[n]) {
          queued[n] = 1;
          next.push_back(n);
        }
      });
    // Every owned neighbour of a cell of this layer lies in the previous
    // layer, so the choice does not depend on the order cells were queued.
    std::vector<WorldId> chosen(next.size(), kNoWorld);
    for (std::size_t j = 0; j < next.size(); ++j)
      for_each_face_neighbour(box, next[j], [&](std::size_t n) {
        const WorldId w = owners[n];
        if (w != kNoWorld && (chosen[j] == kNoWorld || w < chosen[j])) chosen[j] = w;
      });
    for (std::size_t j = 0; j < next.size(); ++j) owners[next[j]] = chosen[j];
    frontier = std::move(next);
  }
}

void enforce_contiguity(const CellBox& box, std::vector<WorldId>& owners, int k,
                        const std::vector<std::int64_t>& weight) {
  // Each move takes a non-main piece of world A to a world B it touches: A
  // loses a piece and B's pieces can only merge, so the total number of
  // pieces falls by at least one per move and the loop ends.
  for (;;) {
    const Pieces p = find_pieces(box, owners);
    const std::size_t count = p.owner.size();
    std::vector<std::int64_t> piece_weight(count, 0);
    for (std::size_t q = 0; q < count; ++q)
      for (std::size_t j = p.start[q]; j < p.start[q + 1]; ++j) piece_weight[q] += weight[p.cells[j]];
    std::vector<std::size_t> main(static_cast<std::size_t>(k), count);
    for (std::size_t q = 0; q < count; ++q) {
      std::size_t& m = main[static_cast<std::size_t>(p.owner[q])];
      const auto size = [&](std::size_t r) { return p.start[r + 1] - p.start[r]; };
      if (m == count || piece_weight[q] > piece_weight[m] ||
          (piece_weight[q] == piece_weight[m] && size(q) > size(m)))
        m = q;  // earlier pieces win ties: they come first in box order
    }
    bool moved_any = false;
    bool fragments = false;
    std::vector<char> changed(owners.size(), 0);
    for (std::size_t q = 0; q < count; ++q) {
      const WorldId w = p.owner[q];
      if (main[static_cast<std::size_t>(w)] == q) continue;
      fragments = true;
      // Only move a piece whose cells and face neighbours are as they were
      // when the pieces were found, so it is still a piece of w.
      bool stale = false;
      std::map<WorldId, std::int64_t> contacts;
      for (std::size_t j = p.start[q]; j < p.start[q + 1] && !stale; ++j) {
        const std::size_t c = p.cells[j];
        if (changed[c]) stale = true;
        for_each_face_neighbour(box, c, [&](std::size_t n) {
          if (changed[n]) stale = true;
          if (owners[n] != w) ++contacts[owners[n]];
        });
      }
      if (stale || contacts.empty()) continue;
      WorldId target = contacts.begin()->first;
      for (const auto& [other, n] : contacts)
        if (n > contacts[target]) target = other;
      for (std::size_t j = p.start[q]; j < p.start[q + 1]; ++j) {
        owners[p.cells[j]] = target;
        changed[p.cells[j]] = 1;
      }
      moved_any = true;
    }
    if (!fragments) return;
    if (!moved_any) throw std::logic_error("enforce_contiguity: no piece could move");
  }
}

void fill_empty_worlds(const CellBox& box, std::vector<WorldId>& owners, int k) {
  std::vector<std::int64_t> count(static_cast<std::size_t>(k), 0);
  for (WorldId w : owners) ++count[static_cast<std::size_t>(w)];
  for (WorldId empty = 0; empty < k; ++empty) {
    if (count[static_cast<std::size_t>(empty)] > 0) continue;
    const auto donor = static_cast<WorldId>(
        std::max_element(count.begin(), count.end()) - count.begin());
    if (count[static_cast<std::size_t>(donor)] < 2)
      throw std::logic_error("fill_empty_worlds: more worlds than cells");
    // The last cell a BFS reaches is a leaf of its tree: removing it keeps
    // the donor connected.
    const auto first = static_cast<std::size_t>(
        std::find(owners.begin(), owners.end(), donor) - owners.begin());
    std::vector<char> seen(owners.size(), 0);
    std::vector<std::size_t> queue{first};
    seen[first] = 1;
    for (std::size_t head = 0; head < queue.size(); ++head)
      for_each_face_neighbour(box, queue[head], [&](std::size_t n) {
        if (!seen[n] && owners[n] == donor) {
          seen[n] = 1;
          queue.push_back(n);
        }
      });
    owners[queue.back()] = empty;
    --count[static_cast<std::size_t>(donor)];
    ++count[static_cast<std::size_t>(empty)];
  }
}

void renumber_canonical(std::vector<WorldId>& owners, int k) {
  std::vector<WorldId> to(static_cast<std::size_t>(k), kNoWorld);
  WorldId next = 0;
  for (WorldId w : owners)
    if (to[static_cast<std::size_t>(w)] == kNoWorld) to[static_cast<std::size_t>(w)] = next++;
  for (WorldId& t : to)
    if (t == kNoWorld) t = next++;
  for (WorldId& w : owners) w = to[static_cast<std::size_t>(w)];
}

int count_pieces(const CellBox& box, std::span<const WorldId> owners, WorldId world) {
  int pieces = 0;
  std::vector<char> seen(owners.size(), 0);
  std::vector<std::size_t> queue;
  for (std::size_t s = 0; s < owners.size(); ++s) {
    if (seen[s] || owners[s] != world) continue;
    ++pieces;
    queue.assign(1, s);
    seen[s] = 1;
    for (std::size_t head = 0; head < queue.size(); ++head)
      for_each_face_neighbour(box, queue[head], [&](std::size_t n) {
        if (!seen[n] && owners[n] == world) {
          seen[n] = 1;
          queue.push_back(n);
        }
      });
  }
  return pieces;
}

}  // namespace soda::detail

namespace soda::detail {

std::vector<int> pieces_per_world(const CellBox& box, std::span<const WorldId> owners, int k) {
  const Pieces p = find_pieces(box, owners);
  std::vector<int> pieces(static_cast<std::size_t>(k), 0);
  for (WorldId w : p.owner) ++pieces[static_cast<std::size_t>(w)];
  return pieces;
}

void verify_partition(const CellBox& box, const std::vector<WorldId>& owners, int k) {
  const std::vector<int> pieces = pieces_per_world(box, owners, k);
  for (int w = 0; w < k; ++w)
    if (pieces[static_cast<std::size_t>(w)] != 1)
      throw std::logic_error("partition: world " + std::to_string(w) + " has " +
                             std::to_string(pieces[static_cast<std::size_t>(w)]) +
                             " pieces (expected exactly one)");
}

}  // namespace soda::detail
