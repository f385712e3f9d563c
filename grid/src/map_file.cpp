// Territory-map files: loading, writing (map_file.h, docs/grid.md). The
// parser is in map_file_parse.cpp.
#include "soda/grid/map_file.h"

#include <fstream>
#include <sstream>

namespace soda {

TerritoryMap load_territory_map(const std::string& path, int k) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw GridError("cannot open territory map '" + path + "'");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw GridError("cannot read territory map '" + path + "'");
  TerritoryMap map = parse_territory_map(text.str(), path);
  if (map.world_count() != k)
    throw GridError("territory map '" + path + "' field worlds: the file has " +
                    std::to_string(map.world_count()) + " worlds but " + std::to_string(k) +
                    " territories were asked for");
  return map;
}

std::string format_territory_map(const TerritoryMap& map) {
  std::ostringstream out;
  out.precision(17);
  const CellBox& b = map.box();
  const Vec3& o = map.grid().origin();
  out << "soda-territory-map 1\n"
      << "# cell size and origin in metres; box in cell coordinates (inclusive)\n"
      << "cell_size " << map.grid().cell_size() << "\n"
      << "origin " << o.x() << " " << o.y() << " " << o.z() << "\n"
      << "box " << b.lo.x << " " << b.lo.y << " " << b.lo.z << " " << b.hi.x << " " << b.hi.y
      << " " << b.hi.z << "\n"
      << "worlds " << map.world_count() << "\n"
      << "# one owner per box cell, x slowest, z fastest; N*W repeats W N times\n"
      << "owners\n";
  const auto owners = map.owners();
  int on_line = 0;
  for (std::size_t i = 0; i < owners.size();) {
    std::size_t j = i;
    while (j < owners.size() && owners[j] == owners[i]) ++j;
    if (j - i > 1) out << (j - i) << "*";
    out << owners[i] << (++on_line % 16 == 0 || j == owners.size() ? "\n" : " ");
    i = j;
  }
  return out.str();
}

void save_territory_map(const TerritoryMap& map, const std::string& path) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw GridError("cannot write territory map '" + path + "'");
  out << format_territory_map(map);
  out.flush();
  if (!out) throw GridError("cannot write territory map '" + path + "'");
}

}  // namespace soda
