#include "soda/scene/obj_mesh.h"

#include <charconv>
#include <cstdlib>
#include <fstream>
#include <string_view>
#include <vector>

#include "soda/scene/validate.h"

namespace soda {
namespace {

std::string_view next_token(std::string_view& line) {
  std::size_t b = 0;
  while (b < line.size() && (line[b] == ' ' || line[b] == '\t' || line[b] == '\r')) ++b;
  std::size_t e = b;
  while (e < line.size() && line[e] != ' ' && line[e] != '\t' && line[e] != '\r') ++e;
  const std::string_view t = line.substr(b, e - b);
  line.remove_prefix(e);
  return t;
}

}  // namespace

std::shared_ptr<const TriangleMeshData> read_obj_mesh(const std::string& path, const std::string& name) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw SceneError(path + ": cannot open the mesh file for reading");
  auto mesh = std::make_shared<TriangleMeshData>();
  mesh->file = name;
  std::string text;
  std::size_t line_no = 0;
  auto fail = [&](const std::string& what) -> void {
    throw SceneError(path + ": line " + std::to_string(line_no) + ": " + what);
  };
  std::vector<std::uint32_t> corners;
  while (std::getline(in, text)) {
    ++line_no;
    std::string_view line(text);
    const std::string_view kind = next_token(line);
    if (kind == "v") {
      Vec3 v;
      for (int k = 0; k < 3; ++k) {
        const std::string t(next_token(line));
        char* end = nullptr;
        v[k] = t.empty() ? 0.0 : std::strtod(t.c_str(), &end);
        if (t.empty() || end != t.c_str() + t.size()) fail("a vertex needs three numbers (v x y z)");
      }
      mesh->vertices.push_back(v);
    } else if (kind == "f") {
      corners.clear();
      for (std::string_view t = next_token(line); !t.empty(); t = next_token(line)) {
        const std::string_view index = t.substr(0, t.find('/'));
        long long i = 0;
        const auto [end, ec] = std::from_chars(index.data(), index.data() + index.size(), i);
        if (ec != std::errc() || end != index.data() + index.size() || i == 0)
          fail("bad face corner '" + std::string(t) + "' (a vertex index from 1, or negative from the last)");
        const long long n = static_cast<long long>(mesh->vertices.size());
        const long long at = i > 0 ? i - 1 : n + i;
        if (at < 0 || at >= n)
          fail("face corner " + std::to_string(i) + " names no vertex (" + std::to_string(n) + " so far)");
        corners.push_back(static_cast<std::uint32_t>(at));
      }
      if (corners.size() < 3) fail("a face needs at least three corners");
      for (std::size_t k = 1; k + 1 < corners.size(); ++k)
        mesh->triangles.push_back({corners[0], corners[k], corners[k + 1]});
    }
  }
  if (in.bad()) throw SceneError(path + ": read error");
  return mesh;
}

}  // namespace soda
