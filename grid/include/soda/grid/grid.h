// grid/ — the geometry of the decomposition, and nothing else.
//
// It owns: the uniform grid (cubic cells at least as large as the largest
// dynamic body), the maps between positions and cells, the territory map
// (cell -> world id, for every cell of Z^3), each world's local grid (its own
// cells plus a one-cell margin), border queries (which foreign cells an AABB
// overlaps) and the initial partitions (equal-size k-means as in the thesis,
// recursive coordinate bisection, regular blocks, territory-map files).
// It knows nothing of Bullet, threads, messages or time steps.
//
// Headers: cell.h (cells, boxes, GridError), grid.h (this one: the uniform
// grid), territory_map.h, local_grid.h, kmeans.h, partition.h, map_file.h.
// Units: metres. Everything computes in double. All types are plain values:
// safe to read from many threads at once, not to mutate concurrently.
//
// Invariants of the uniform grid (kept by UniformGrid):
//  1. cells are cubes of edge cell_size > 0 anchored at origin: cell c spans
//     [origin + c * cell_size, origin + (c + 1) * cell_size) on each axis;
//  2. cell_of(p) is floor((p - origin) / cell_size) per axis in double with
//     no fused operations: a position always lands in the same cell, on every
//     machine; a point exactly on a cell boundary belongs to the upper cell;
//  3. cell coordinates saturate at +-kMaxCellIndex, so every finite position
//     has a cell; a non-finite position is an error, never a cell;
//  4. a body may be larger than a cell: it then spans several cells, and
//     its halo (the AABB the partitioned step ghosts by) reaches every cell
//     it overlaps; the neighbours of a territory reach as far as the largest
//     body does (reach.h).
#pragma once

#include <cmath>
#include <cstdint>
#include <optional>

#include "soda/grid/cell.h"
#include "soda/scene/scene.h"

namespace soda {

/// Cell size used when a scene has no dynamic body to size cells by. Metres.
inline constexpr double kDefaultCellSize = 1.0;
/// Most cells a box of cells may hold: 2^24 cells keep a territory map at
/// 64 MiB. Scenes that need more should use larger cells.
inline constexpr std::int64_t kMaxBoxCells = std::int64_t{1} << 24;

/// A uniform grid of cubic cells. Plain value; all members are const and
/// thread-safe to call concurrently.
class UniformGrid {
 public:
  /// Unit cells at the origin.
  UniformGrid() = default;
  /// Throws GridError unless origin is finite and cell_size is finite and > 0.
  UniformGrid(const Vec3& origin, double cell_size);

  /// Corner of cell (0, 0, 0), metres.
  const Vec3& origin() const { return origin_; }
  /// Edge length of a cell, metres.
  double cell_size() const { return cell_size_; }

  /// Cell holding position p (invariants 2 and 3). Throws GridError if p is
  /// not finite. Inline: it runs several times per body and step.
  CellCoord cell_of(const Vec3& p) const {
    if (!finite(p)) throw_position_not_finite(p);
    return cell_of_finite(p);
  }
  /// Lower corner of a cell (origin + c * cell_size).
  Vec3 cell_min(const CellCoord& c) const;
  /// Upper corner of a cell (origin + (c + 1) * cell_size).
  Vec3 cell_max(const CellCoord& c) const;
  /// Centre of a cell.
  Vec3 cell_center(const CellCoord& c) const;
  /// Cells overlapped by the closed AABB [min, max]: cell_of(min) ..
  /// cell_of(max). A box touching a cell boundary from below counts as
  /// overlapping the upper cell (conservative). Throws GridError if a corner
  /// is not finite or min > max on some axis.
  CellBox cells_overlapping(const Vec3& min, const Vec3& max) const {
    if (!finite(min) || !finite(max)) throw_aabb_not_finite(min, max);
    if (min.x() > max.x() || min.y() > max.y() || min.z() > max.z()) throw_min_exceeds_max(min, max);
    return {cell_of_finite(min), cell_of_finite(max)};
  }

  friend bool operator==(const UniformGrid&, const UniformGrid&) = default;

 private:
  static bool finite(const Vec3& v) {
    return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z());
  }
  // std::clamp(std::floor(t), -kMaxCellIndex, kMaxCellIndex) as an int, for
  // every t that is not NaN, without a libm call: |t| >= 2^29 saturates;
  // below, the conversion to int truncates exactly, and truncation rounds a
  // negative non-integer up, which one subtraction corrects (-0.0 gives 0).
  static int floor_cell(double t) {
    constexpr double kLimit = kMaxCellIndex;
    if (!(std::fabs(t) < kLimit)) return t > 0.0 ? kMaxCellIndex : -kMaxCellIndex;
    const int i = static_cast<int>(t);
    return static_cast<double>(i) > t ? i - 1 : i;
  }
  // (p - origin) / cell_size per axis, in double (never NaN for finite p:
  // at worst +-inf, which saturates). Forced inline: GCC keeps it out of
  // line in large callers (callgrind: ~10 instructions a call).
  [[gnu::always_inline]] CellCoord cell_of_finite(const Vec3& p) const {
    return {floor_cell((p.x() - origin_.x()) / cell_size_), floor_cell((p.y() - origin_.y()) / cell_size_),
            floor_cell((p.z() - origin_.z()) / cell_size_)};
  }
  [[noreturn]] static void throw_position_not_finite(const Vec3& p);
  [[noreturn]] static void throw_aabb_not_finite(const Vec3& min, const Vec3& max);
  [[noreturn]] static void throw_min_exceeds_max(const Vec3& min, const Vec3& max);

  Vec3 origin_ = Vec3::Zero();
  double cell_size_ = 1.0;
};

/// The documented weight of one triangle within a cell's reach against one
/// dynamic body (cell_triangles.h; docs/loadbalance.md, "Triangles"):
/// callgrind on terrain 200, steps 60 to 120, one world: an awake body
/// costs 93,152 instructions a step, 61,278 of them in the narrowphase of
/// its triangles, with 90.5 triangles within its home cell's reach, so a
/// triangle within reach weighs 61,278 / 90.5 / 31,874 = 0.021 of the rest
/// of a body (bench/triangle_cost.py, docs/results/triangle-cost.md).
inline constexpr double kTriangleWeight = 0.02;

/// How to lay the grid over a scene and how to partition it. Plain value.
struct GridOptions {
  /// Cell size override, metres, finite and > 0 (else GridError). Unset:
  /// default_cell_size(scene).
  std::optional<double> cell_size;
  /// Grid origin, metres: cell boundaries lie at origin + i * cell_size. Put a
  /// border at an exact coordinate by choosing origin and box together.
  Vec3 origin = Vec3::Zero();
  /// Explicit box of cells for the territory map. Unset: the cells overlapped
  /// by the dynamic bodies' AABBs, grown by margin_cells.
  std::optional<CellBox> box;
  /// Cells added on every side of the scene's bounds (>= 0).
  int margin_cells = 1;
  /// Seed of the k-means initialisation.
  std::uint64_t seed = 1;
  /// Cap on k-means (Lloyd) iterations.
  int kmeans_max_iterations = 100;
  /// kmeans and rcb weigh each dynamic body by 1 + triangle_weight x the
  /// triangles of static meshes and heightfields within its home cell's
  /// reach (cell_triangles.h); 0: every body weighs 1. Finite and >= 0.
  double triangle_weight = kTriangleWeight;
};

/// The grid for a scene: origin from options, cell size per invariant 4.
/// Throws GridError if the override is smaller than the largest dynamic body
/// (the message gives both numbers) or not finite and positive.
UniformGrid make_grid(const Scene& scene, const GridOptions& options);

/// The cell size a scene gets by default: the extent (bounding-sphere
/// diameter, so that rotation never makes it larger) that 90 % of its dynamic
/// bodies do not exceed — the largest body's when all are alike, a unit
/// cube's when a few large bodies (a plank, a vehicle, a ship) stand among
/// many cubes, which then span several cells each instead of making every
/// cell as large as they are. kDefaultCellSize when nothing moves.
double default_cell_size(const Scene& scene);

/// The territory map's box: options.box if set, else the cells overlapped by
/// the dynamic bodies' initial AABBs (the static bodies' positions if there is
/// no dynamic body, cell (0,0,0) if there is no body) grown by
/// options.margin_cells. Throws GridError for an invalid box, a negative
/// margin, or a box of more than kMaxBoxCells cells.
CellBox make_box(const Scene& scene, const UniformGrid& grid, const GridOptions& options);

}  // namespace soda
