// Cells of the uniform grid: integer cell coordinates, inclusive boxes of
// cells, and GridError, the one error type of grid/. See grid.h for what the
// folder owns.
//
// Everything here is a plain value: safe to read from many threads at once,
// not to mutate concurrently.
#pragma once

#include <compare>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <stdexcept>
#include <string>

namespace soda {

/// Error raised by grid/ for invalid parameters, partition specs and
/// territory-map files. The message says what was wrong and, for files, where
/// (file name and line or field).
class GridError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// Largest |coordinate| of a cell. Positions further from the origin than
/// kMaxCellIndex cells saturate to the outermost cell (see UniformGrid).
inline constexpr int kMaxCellIndex = 1 << 29;

/// Integer coordinates of one grid cell. Ordered lexicographically by
/// (x, y, z); this is the canonical order of every cell list in grid/.
struct CellCoord {
  int x = 0;
  int y = 0;
  int z = 0;

  /// Coordinate along axis 0 (x), 1 (y) or 2 (z).
  int operator[](int axis) const { return axis == 0 ? x : (axis == 1 ? y : z); }
  int& operator[](int axis) { return axis == 0 ? x : (axis == 1 ? y : z); }

  friend bool operator==(const CellCoord&, const CellCoord&) = default;
  friend auto operator<=>(const CellCoord&, const CellCoord&) = default;
};

/// "(x, y, z)", for messages.
std::string to_string(const CellCoord& cell);

/// Hash of a cell for unordered containers. Never iterate such a container
/// to produce results: grid/ promises orders that do not depend on hashing.
struct CellCoordHash {
  std::size_t operator()(const CellCoord& cell) const noexcept;
};

/// Inclusive box of cells [lo, hi] per axis. Its linear index runs x slowest,
/// z fastest, so index order equals the canonical (lexicographic) cell order.
/// A box is valid when lo <= hi on every axis.
struct CellBox {
  CellCoord lo;
  CellCoord hi;

  /// True when lo <= hi on every axis (the box holds at least one cell).
  bool valid() const { return lo.x <= hi.x && lo.y <= hi.y && lo.z <= hi.z; }
  /// Number of cells along axis 0, 1 or 2 (valid boxes only).
  std::int64_t extent(int axis) const {
    return static_cast<std::int64_t>(hi[axis]) - lo[axis] + 1;
  }
  /// Number of cells; saturates at INT64_MAX for absurd boxes; 0 if invalid.
  std::int64_t count() const;
  /// True if c lies in the box.
  bool contains(const CellCoord& c) const {
    return c.x >= lo.x && c.x <= hi.x && c.y >= lo.y && c.y <= hi.y && c.z >= lo.z &&
           c.z <= hi.z;
  }
  /// The cell of the box nearest to c (each coordinate clamped into [lo, hi]).
  CellCoord clamp(const CellCoord& c) const {
    return {clamp1(c.x, lo.x, hi.x), clamp1(c.y, lo.y, hi.y), clamp1(c.z, lo.z, hi.z)};
  }
  /// Linear index of a cell of the box. Precondition: contains(c).
  std::size_t index(const CellCoord& c) const {
    return static_cast<std::size_t>(
        ((static_cast<std::int64_t>(c.x) - lo.x) * extent(1) + (c.y - lo.y)) * extent(2) +
        (c.z - lo.z));
  }
  /// Inverse of index(). Precondition: i < count().
  CellCoord cell_at(std::size_t i) const;
  /// The box grown by `margin` cells on every side (margin may be negative).
  CellBox grown(int margin) const;

  friend bool operator==(const CellBox&, const CellBox&) = default;

 private:
  // std::clamp for ints, without <algorithm> in this header.
  static int clamp1(int v, int low, int high) { return v < low ? low : (high < v ? high : v); }
};

/// "[(lo) .. (hi)]", for messages.
std::string to_string(const CellBox& box);

}  // namespace soda

template <>
struct std::hash<soda::CellCoord> {
  std::size_t operator()(const soda::CellCoord& c) const noexcept {
    return soda::CellCoordHash{}(c);
  }
};
