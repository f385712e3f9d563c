// CellCoord, CellBox (cell.h).
#include "soda/grid/cell.h"

#include <limits>

namespace soda {

// Built by appending: GCC 12 warns falsely (-Wrestrict) on "(" + string&&.
std::string to_string(const CellCoord& cell) {
  std::string s = "(";
  s += std::to_string(cell.x);
  s += ", ";
  s += std::to_string(cell.y);
  s += ", ";
  s += std::to_string(cell.z);
  s += ")";
  return s;
}

std::string to_string(const CellBox& box) {
  std::string s = "[";
  s += to_string(box.lo);
  s += " .. ";
  s += to_string(box.hi);
  s += "]";
  return s;
}

std::size_t CellCoordHash::operator()(const CellCoord& cell) const noexcept {
  // splitmix64 finaliser over the packed coordinates.
  std::uint64_t h = static_cast<std::uint32_t>(cell.x);
  h = h * 0x9E3779B97F4A7C15ULL ^ static_cast<std::uint32_t>(cell.y);
  h = h * 0x9E3779B97F4A7C15ULL ^ static_cast<std::uint32_t>(cell.z);
  h ^= h >> 30;
  h *= 0xBF58476D1CE4E5B9ULL;
  h ^= h >> 27;
  h *= 0x94D049BB133111EBULL;
  h ^= h >> 31;
  return static_cast<std::size_t>(h);
}

std::int64_t CellBox::count() const {
  if (!valid()) return 0;
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  std::int64_t n = 1;
  for (int axis = 0; axis < 3; ++axis) {
    const std::int64_t e = extent(axis);
    if (n > kMax / e) return kMax;
    n *= e;
  }
  return n;
}

CellCoord CellBox::cell_at(std::size_t i) const {
  const auto ey = static_cast<std::size_t>(extent(1));
  const auto ez = static_cast<std::size_t>(extent(2));
  const std::size_t z = i % ez;
  const std::size_t y = (i / ez) % ey;
  const std::size_t x = i / (ez * ey);
  return {lo.x + static_cast<int>(x), lo.y + static_cast<int>(y), lo.z + static_cast<int>(z)};
}

CellBox CellBox::grown(int margin) const {
  return {{lo.x - margin, lo.y - margin, lo.z - margin},
          {hi.x + margin, hi.y + margin, hi.z + margin}};
}

}  // namespace soda
