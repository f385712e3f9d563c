// Territory-map files: a small line-based text format (docs/grid.md):
//
//   soda-territory-map 1
//   cell_size 2.0               # metres
//   origin 0 0 0                # metres, optional (default 0 0 0)
//   box -2 0 0 1 1 1            # inclusive cell box: lo x y z, hi x y z
//   worlds 2
//   planes x 0                  # either planes (per axis, cell indices) ...
//   owners 8*0 8*1              # ... or one owner per box cell, x slowest
//
// Invariants of a loaded map: those of partition.h (ids 0..worlds-1, every
// world owns a cell, every territory 6-connected).
#pragma once

#include <string>
#include <string_view>

#include "soda/grid/territory_map.h"

namespace soda {

/// Parses territory-map text. `source` names the text in messages (a file
/// name). Throws GridError "territory map 'source' line N: ..." for a syntax
/// error, a missing or repeated field, an owner out of range, a world owning
/// no cell or a disconnected territory. Pure function; thread-safe.
TerritoryMap parse_territory_map(std::string_view text, const std::string& source);

/// Reads and parses a file, then checks it against a territory count:
/// worlds == k. Any cell size is accepted (bodies larger than a cell span
/// several). Throws GridError naming the file (and the line or field) on
/// any failure, including a file that cannot be read.
TerritoryMap load_territory_map(const std::string& path, int k);

/// The map in the file format, owners written per box cell with run-length
/// "N*W" tokens; parse_territory_map(format_territory_map(m)) == m.
std::string format_territory_map(const TerritoryMap& map);

/// Writes format_territory_map(map) to a file. Throws GridError naming the
/// file if it cannot be written.
void save_territory_map(const TerritoryMap& map, const std::string& path);

}  // namespace soda
