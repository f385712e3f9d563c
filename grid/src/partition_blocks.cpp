// Regular blocks (spec "grid:AxBxC"), see partition.h.
#include <array>
#include <cctype>

#include "partition_detail.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

/// Largest slab count accepted per axis (keeps A * B * C exact in 64 bits).
constexpr int kMaxSlabs = 1 << 20;

}  // namespace

BlockSpec parse_block_spec(const std::string& spec) {
  const auto bad = [&](const std::string& why) {
    return GridError("bad block spec '" + spec + "' (" + why +
                     "): expected grid:AxBxC with positive integers A, B, C, the slabs along "
                     "x, y and z, e.g. grid:2x1x1");
  };
  if (!spec.starts_with("grid:")) throw bad("missing 'grid:'");
  std::array<int, 3> v{};
  std::size_t pos = 5;
  for (int axis = 0; axis < 3; ++axis) {
    std::size_t end = pos;
    while (end < spec.size() && std::isdigit(static_cast<unsigned char>(spec[end]))) ++end;
    if (end == pos) throw bad("a count is missing or not a number");
    if (end - pos > 7) throw bad("a count is too large");
    v[static_cast<std::size_t>(axis)] = std::stoi(spec.substr(pos, end - pos));
    if (v[static_cast<std::size_t>(axis)] < 1 || v[static_cast<std::size_t>(axis)] > kMaxSlabs)
      throw bad("counts must be between 1 and " + std::to_string(kMaxSlabs));
    pos = end;
    if (axis < 2) {
      if (pos >= spec.size() || spec[pos] != 'x') throw bad("counts must be separated by 'x'");
      ++pos;
    }
  }
  if (pos != spec.size()) throw bad("unexpected text after the third count");
  return {v[0], v[1], v[2]};
}

TerritoryMap partition_blocks(const BlockSpec& blocks, const Scene& scene, int k,
                              const GridOptions& options) {
  const std::array<int, 3> slabs{blocks.a, blocks.b, blocks.c};
  for (int s : slabs)
    if (s < 1 || s > kMaxSlabs)
      throw GridError("grid blocks: slab counts must be between 1 and " +
                      std::to_string(kMaxSlabs));
  const std::string name = "grid:" + std::to_string(blocks.a) + "x" + std::to_string(blocks.b) +
                           "x" + std::to_string(blocks.c);
  const std::int64_t total = std::int64_t{blocks.a} * blocks.b * blocks.c;
  if (total != k)
    throw GridError(name + " makes " + std::to_string(total) +
                    " territories but the number of territories asked for is " +
                    std::to_string(k));
  const UniformGrid grid = make_grid(scene, options);
  const CellBox box = make_box(scene, grid, options);
  // slab_of[axis][offset]: slab i holds offsets floor(i*n/A) .. floor((i+1)*n/A) - 1.
  std::array<std::vector<int>, 3> slab_of;
  static constexpr const char* kAxis[3] = {"x", "y", "z"};
  for (int axis = 0; axis < 3; ++axis) {
    const std::int64_t n = box.extent(axis);
    const int count = slabs[static_cast<std::size_t>(axis)];
    if (n < count)
      throw GridError(name + ": the grid box " + to_string(box) + " has only " +
                      std::to_string(n) + " cells along " + kAxis[axis] + ", fewer than the " +
                      std::to_string(count) +
                      " slabs asked for; use smaller cells, a larger margin or an explicit box");
    auto& of = slab_of[static_cast<std::size_t>(axis)];
    of.resize(static_cast<std::size_t>(n));
    for (int i = 0; i < count; ++i)
      for (std::int64_t o = i * n / count; o < (i + 1) * n / count; ++o)
        of[static_cast<std::size_t>(o)] = i;
  }
  detail::check_world_count(k, box, name.c_str());
  std::vector<WorldId> owners(static_cast<std::size_t>(box.count()));
  for (std::size_t i = 0; i < owners.size(); ++i) {
    const CellCoord c = box.cell_at(i);
    const int sx = slab_of[0][static_cast<std::size_t>(c.x - box.lo.x)];
    const int sy = slab_of[1][static_cast<std::size_t>(c.y - box.lo.y)];
    const int sz = slab_of[2][static_cast<std::size_t>(c.z - box.lo.z)];
    owners[i] = (sx * blocks.b + sy) * blocks.c + sz;
  }
  return TerritoryMap(grid, box, std::move(owners), k);
}

}  // namespace soda
