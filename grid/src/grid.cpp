// UniformGrid, make_grid, make_box (grid.h).
#include "soda/grid/grid.h"

#include <algorithm>
#include <cmath>
#include <vector>
#include <sstream>

namespace soda {
namespace {

std::string fmt(double v) {
  std::ostringstream s;
  s.precision(17);
  s << v;
  return s.str();
}

std::string fmt(const Vec3& v) { return "(" + fmt(v.x()) + ", " + fmt(v.y()) + ", " + fmt(v.z()) + ")"; }

void check_box(const CellBox& box, const char* what) {
  if (!box.valid())
    throw GridError(std::string(what) + " " + to_string(box) + " is empty (lo > hi on some axis)");
  for (int axis = 0; axis < 3; ++axis)
    if (std::abs(static_cast<std::int64_t>(box.lo[axis])) > kMaxCellIndex ||
        std::abs(static_cast<std::int64_t>(box.hi[axis])) > kMaxCellIndex)
      throw GridError(std::string(what) + " " + to_string(box) +
                      " has a coordinate beyond +-kMaxCellIndex (" +
                      std::to_string(kMaxCellIndex) + ")");
  if (box.count() > kMaxBoxCells)
    throw GridError(std::string(what) + " " + to_string(box) + " holds " +
                    std::to_string(box.count()) + " cells, more than the limit of " +
                    std::to_string(kMaxBoxCells) + "; use a larger cell size");
}

}  // namespace

UniformGrid::UniformGrid(const Vec3& origin, double cell_size)
    : origin_(origin), cell_size_(cell_size) {
  if (!finite(origin)) throw GridError("grid origin " + fmt(origin) + " is not finite");
  if (!std::isfinite(cell_size) || !(cell_size > 0.0))
    throw GridError("grid cell size " + fmt(cell_size) + " must be finite and > 0");
}

void UniformGrid::throw_position_not_finite(const Vec3& p) {
  throw GridError("cell_of: position " + fmt(p) + " is not finite");
}

void UniformGrid::throw_aabb_not_finite(const Vec3& min, const Vec3& max) {
  throw GridError("cells_overlapping: AABB " + fmt(min) + " .. " + fmt(max) + " is not finite");
}

void UniformGrid::throw_min_exceeds_max(const Vec3& min, const Vec3& max) {
  throw GridError("cells_overlapping: AABB min " + fmt(min) + " exceeds max " + fmt(max));
}

Vec3 UniformGrid::cell_min(const CellCoord& c) const {
  return {origin_.x() + c.x * cell_size_, origin_.y() + c.y * cell_size_,
          origin_.z() + c.z * cell_size_};
}

Vec3 UniformGrid::cell_max(const CellCoord& c) const {
  return cell_min({c.x + 1, c.y + 1, c.z + 1});
}

Vec3 UniformGrid::cell_center(const CellCoord& c) const {
  const Vec3 lo = cell_min(c);
  const double h = 0.5 * cell_size_;
  return {lo.x() + h, lo.y() + h, lo.z() + h};
}

double default_cell_size(const Scene& scene) {
  std::vector<double> extents;
  for (const Body& b : scene.bodies)
    if (!b.is_static) extents.push_back(2.0 * b.shape.bounding_radius());
  if (extents.empty()) return kDefaultCellSize;
  // The smallest extent at least 90 % of the bodies do not exceed: rank
  // ceil(0.9 n) of n, counted from 1.
  const std::size_t rank = (9 * extents.size() + 9) / 10;
  std::nth_element(extents.begin(), extents.begin() + static_cast<std::ptrdiff_t>(rank - 1), extents.end());
  const double e = extents[rank - 1];
  return e > 0.0 ? e : kDefaultCellSize;
}

UniformGrid make_grid(const Scene& scene, const GridOptions& options) {
  if (!options.cell_size) return UniformGrid(options.origin, default_cell_size(scene));
  const double size = *options.cell_size;
  if (!std::isfinite(size) || !(size > 0.0))
    throw GridError("cell size override " + fmt(size) + " m must be finite and > 0");
  return UniformGrid(options.origin, size);
}

CellBox make_box(const Scene& scene, const UniformGrid& grid, const GridOptions& options) {
  if (options.box) {
    check_box(*options.box, "explicit grid box");
    return *options.box;
  }
  if (options.margin_cells < 0 || options.margin_cells > kMaxCellIndex)
    throw GridError("grid margin " + std::to_string(options.margin_cells) +
                    " cells must be >= 0 and <= kMaxCellIndex");
  const bool has_dynamic = scene.dynamic_count() > 0;
  bool any = false;
  CellBox box{{0, 0, 0}, {0, 0, 0}};
  for (const Body& body : scene.bodies) {
    if (has_dynamic && body.is_static) continue;
    // Statics only stand in when nothing moves; their centres, not their
    // extents (a ground plane would otherwise span the world).
    const Vec3 h = has_dynamic ? body.aabb_half_extents() : Vec3::Zero();
    const CellBox b = grid.cells_overlapping(body.position - h, body.position + h);
    if (!any) {
      box = b;
      any = true;
    } else {
      for (int axis = 0; axis < 3; ++axis) {
        box.lo[axis] = std::min(box.lo[axis], b.lo[axis]);
        box.hi[axis] = std::max(box.hi[axis], b.hi[axis]);
      }
    }
  }
  box = box.grown(options.margin_cells);
  check_box(box, "scene grid box");
  return box;
}

}  // namespace soda
