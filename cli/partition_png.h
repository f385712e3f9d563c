// cli/ — `soda partition --png FILE`: a picture of a territory map.
#pragma once

#include <string>

#include "soda/grid/territory_map.h"
#include "soda/scene/scene.h"

namespace soda::cli {

/// Most pixels along the longer side of a partition picture.
inline constexpr int kPartitionPngMaxPixels = 800;

/// Writes an 8-bit RGB PNG of `map` seen from above (+x to the right, +z
/// down): one square per (x, z) column of the map's box, coloured by the
/// owner of the column's cell in the layer (y) holding most of the scene's
/// dynamic bodies (the viewer's palette, docs/viewer.md "Colours"; world w
/// in colour w % 12), a dark line where neighbouring squares have different
/// owners, and every dynamic body's centre as a dark dot. The layer drawn is
/// returned (a cell row index of the box). Throws std::runtime_error naming
/// `path` if the file cannot be written.
int write_partition_png(const std::string& path, const TerritoryMap& map, const Scene& scene);

}  // namespace soda::cli
