// Territory-map files: the parser (map_file.h, docs/grid.md).
#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <map>
#include <sstream>

#include "partition_detail.h"
#include "soda/grid/map_file.h"

namespace soda {
namespace {

struct Line {
  int number = 0;
  std::vector<std::string> tokens;
};

// Non-empty lines, comments ('#' to end of line) removed, split on blanks.
std::vector<Line> split_lines(std::string_view text) {
  std::vector<Line> lines;
  int number = 0;
  for (std::size_t pos = 0; pos <= text.size();) {
    std::size_t end = text.find('\n', pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view line = text.substr(pos, end - pos);
    ++number;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos)
      line = line.substr(0, hash);
    std::istringstream words{std::string(line)};
    Line parsed{number, {}};
    for (std::string w; words >> w;) parsed.tokens.push_back(w);
    if (!parsed.tokens.empty()) lines.push_back(std::move(parsed));
    pos = end + 1;
  }
  return lines;
}

// The fields of a file, as read; owners still unexpanded.
struct Fields {
  std::map<std::string, int> line_of;  // field name -> line it is on
  double cell_size = 0.0;
  Vec3 origin = Vec3::Zero();
  CellBox box;
  int worlds = 0;
  std::array<std::vector<int>, 3> planes;
  std::array<int, 3> plane_line{0, 0, 0};
  std::vector<std::pair<std::string, int>> owner_tokens;  // token, line
};

class Parser {
 public:
  explicit Parser(const std::string& source) : source_(source) {}

  GridError error(int line, const std::string& what) const {
    return GridError("territory map '" + source_ + "' line " + std::to_string(line) + ": " + what);
  }
  GridError error(const std::string& what) const {
    return GridError("territory map '" + source_ + "': " + what);
  }

  template <class T>
  T number(int line, const std::string& token, const char* field) const {
    T value{};
    const char* end = token.data() + token.size();
    const auto [ptr, ec] = std::from_chars(token.data(), end, value);
    bool ok = ec == std::errc() && ptr == end;
    if constexpr (std::is_floating_point_v<T>) ok = ok && std::isfinite(value);
    if (!ok)
      throw error(line, "'" + token + "' is not a valid " +
                            (std::is_floating_point_v<T> ? "number" : "integer") + " for '" +
                            field + "'");
    return value;
  }

  void arity(const Line& line, std::size_t n, const char* usage) const {
    if (line.tokens.size() != n + 1) throw error(line.number, "expected '" + std::string(usage) + "'");
  }

  Fields read_fields(const std::vector<Line>& lines) const;
  std::vector<WorldId> owners_from_planes(Fields& f) const;
  std::vector<WorldId> owners_from_list(const Fields& f) const;

 private:
  void read_box(const Line& line, Fields& f) const;
  const std::string& source_;
};

void Parser::read_box(const Line& line, Fields& f) const {
  arity(line, 6, "box <lo x> <lo y> <lo z> <hi x> <hi y> <hi z>");
  for (int a = 0; a < 3; ++a) {
    f.box.lo[a] = number<int>(line.number, line.tokens[static_cast<std::size_t>(1 + a)], "box");
    f.box.hi[a] = number<int>(line.number, line.tokens[static_cast<std::size_t>(4 + a)], "box");
    if (std::abs(static_cast<std::int64_t>(f.box.lo[a])) > kMaxCellIndex ||
        std::abs(static_cast<std::int64_t>(f.box.hi[a])) > kMaxCellIndex)
      throw error(line.number, "box coordinates must lie within +-" + std::to_string(kMaxCellIndex));
  }
  if (!f.box.valid()) throw error(line.number, "box lo must be <= hi on every axis");
  if (f.box.count() > kMaxBoxCells)
    throw error(line.number, "box holds " + std::to_string(f.box.count()) +
                                 " cells, more than the limit of " + std::to_string(kMaxBoxCells));
}

Fields Parser::read_fields(const std::vector<Line>& lines) const {
  if (lines.empty()) throw error("the file is empty; expected 'soda-territory-map 1'");
  const Line& head = lines.front();
  if (head.tokens[0] != "soda-territory-map" || head.tokens.size() != 2)
    throw error(head.number, "expected the header 'soda-territory-map 1'");
  if (head.tokens[1] != "1")
    throw error(head.number, "unsupported version '" + head.tokens[1] + "' (this reader knows 1)");
  Fields f;
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const Line& line = lines[i];
    const std::string& key = line.tokens[0];
    std::string field = key;
    int axis = -1;
    if (key == "planes") {
      if (line.tokens.size() < 2 || line.tokens[1].size() != 1 ||
          std::string("xyz").find(line.tokens[1]) == std::string::npos)
        throw error(line.number, "expected 'planes x|y|z <cell index> ...'");
      axis = static_cast<int>(std::string("xyz").find(line.tokens[1]));
      field += " " + line.tokens[1];
    }
    if (f.line_of.count(field))
      throw error(line.number, "'" + field + "' repeated (first on line " +
                                   std::to_string(f.line_of[field]) + ")");
    f.line_of[field] = line.number;
    if (key == "cell_size") {
      arity(line, 1, "cell_size <metres>");
      f.cell_size = number<double>(line.number, line.tokens[1], "cell_size");
      if (!(f.cell_size > 0.0)) throw error(line.number, "cell_size must be > 0");
    } else if (key == "origin") {
      arity(line, 3, "origin <x> <y> <z>");
      for (int a = 0; a < 3; ++a)
        f.origin[a] = number<double>(line.number, line.tokens[static_cast<std::size_t>(1 + a)], "origin");
    } else if (key == "box") {
      read_box(line, f);
    } else if (key == "worlds") {
      arity(line, 1, "worlds <count>");
      f.worlds = number<int>(line.number, line.tokens[1], "worlds");
      if (f.worlds < 1) throw error(line.number, "worlds must be >= 1");
    } else if (axis >= 0) {
      f.plane_line[static_cast<std::size_t>(axis)] = line.number;
      for (std::size_t t = 2; t < line.tokens.size(); ++t)
        f.planes[static_cast<std::size_t>(axis)].push_back(number<int>(line.number, line.tokens[t], "planes"));
    } else if (key == "owners") {
      for (std::size_t j = i; j < lines.size(); ++j)  // owners take the rest of the file
        for (std::size_t t = (j == i ? 1 : 0); t < lines[j].tokens.size(); ++t)
          f.owner_tokens.emplace_back(lines[j].tokens[t], lines[j].number);
      break;
    } else {
      throw error(line.number, "unknown field '" + key +
                                   "'; expected cell_size, origin, box, worlds, planes or owners");
    }
  }
  for (const char* need : {"cell_size", "box", "worlds"})
    if (!f.line_of.count(need)) throw error(std::string("missing field '") + need + "'");
  const bool planes = f.line_of.count("planes x") || f.line_of.count("planes y") ||
                      f.line_of.count("planes z");
  if (planes == (f.line_of.count("owners") > 0))
    throw error("needs exactly one of 'owners' or 'planes' (see docs/grid.md)");
  if (f.worlds > f.box.count())
    throw error(f.line_of["worlds"], std::to_string(f.worlds) + " worlds cannot share the " +
                                         std::to_string(f.box.count()) + " cells of the box");
  return f;
}

std::vector<WorldId> Parser::owners_from_planes(Fields& f) const {
  const CellBox& box = f.box;
  std::array<std::vector<int>, 3> slab_of;
  std::int64_t product = 1;
  for (int a = 0; a < 3; ++a) {
    const auto& cuts = f.planes[static_cast<std::size_t>(a)];
    for (std::size_t j = 0; j < cuts.size(); ++j)
      if (cuts[j] <= box.lo[a] || cuts[j] > box.hi[a] || (j > 0 && cuts[j] <= cuts[j - 1]))
        throw error(f.plane_line[static_cast<std::size_t>(a)],
                    "planes must increase strictly and lie in (" + std::to_string(box.lo[a]) +
                        ", " + std::to_string(box.hi[a]) + "] (cell indices inside the box)");
    product *= static_cast<std::int64_t>(cuts.size()) + 1;
    for (int c = box.lo[a]; c <= box.hi[a]; ++c)  // slab = number of planes <= c
      slab_of[static_cast<std::size_t>(a)].push_back(
          static_cast<int>(std::upper_bound(cuts.begin(), cuts.end(), c) - cuts.begin()));
  }
  if (product != f.worlds)
    throw error(f.line_of["worlds"], "the planes make " + std::to_string(product) +
                                         " blocks but worlds is " + std::to_string(f.worlds));
  const auto ny = static_cast<int>(f.planes[1].size()) + 1;
  const auto nz = static_cast<int>(f.planes[2].size()) + 1;
  std::vector<WorldId> owners(static_cast<std::size_t>(box.count()));
  for (std::size_t i = 0; i < owners.size(); ++i) {
    const CellCoord c = box.cell_at(i);
    owners[i] = (slab_of[0][static_cast<std::size_t>(c.x - box.lo.x)] * ny +
                 slab_of[1][static_cast<std::size_t>(c.y - box.lo.y)]) * nz +
                slab_of[2][static_cast<std::size_t>(c.z - box.lo.z)];
  }
  return owners;
}

std::vector<WorldId> Parser::owners_from_list(const Fields& f) const {
  const auto n_cells = static_cast<std::size_t>(f.box.count());
  std::vector<WorldId> owners;
  owners.reserve(n_cells);
  int last_line = f.line_of.at("owners");
  for (const auto& [token, line] : f.owner_tokens) {
    last_line = line;
    std::int64_t repeat = 1;
    std::string value = token;
    if (const std::size_t star = token.find('*'); star != std::string::npos) {
      repeat = number<std::int64_t>(line, token.substr(0, star), "owners");
      value = token.substr(star + 1);
      if (repeat < 1) throw error(line, "repeat count in '" + token + "' must be >= 1");
    }
    const int w = number<int>(line, value, "owners");
    if (w < 0 || w >= f.worlds)
      throw error(line, "owner " + std::to_string(w) + " is outside 0.." + std::to_string(f.worlds - 1));
    if (repeat > static_cast<std::int64_t>(n_cells - owners.size()))
      throw error(line, "more owners than the " + std::to_string(n_cells) + " cells of the box");
    owners.insert(owners.end(), static_cast<std::size_t>(repeat), w);
  }
  if (owners.size() != n_cells)
    throw error(last_line, "expected " + std::to_string(n_cells) + " owners (" +
                               std::to_string(f.box.extent(0)) + "x" + std::to_string(f.box.extent(1)) +
                               "x" + std::to_string(f.box.extent(2)) +
                               " box cells, x slowest, z fastest), got " + std::to_string(owners.size()));
  return owners;
}

}  // namespace

TerritoryMap parse_territory_map(std::string_view text, const std::string& source) {
  const Parser p(source);
  Fields f = p.read_fields(split_lines(text));
  std::vector<WorldId> owners =
      f.line_of.count("owners") ? p.owners_from_list(f) : p.owners_from_planes(f);
  const std::vector<int> pieces = detail::pieces_per_world(f.box, owners, f.worlds);
  for (int w = 0; w < f.worlds; ++w) {
    const int n = pieces[static_cast<std::size_t>(w)];
    if (n == 0) throw p.error("world " + std::to_string(w) + " owns no cell of the box");
    if (n > 1)
      throw p.error("world " + std::to_string(w) + " is not connected: its cells form " +
                    std::to_string(n) + " separate pieces under face adjacency");
  }
  return TerritoryMap(UniformGrid(f.origin, f.cell_size), f.box, std::move(owners), f.worlds);
}

}  // namespace soda
