#include "partition_png.h"

#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace soda::cli {
namespace {

// viewer/web/palette.js: WORLD_COLOURS, BACKGROUND_COLOUR.
constexpr std::array<std::uint32_t, 12> kWorldColours = {0xe6194b, 0x3cb44b, 0x4363d8, 0xf58231, 0x911eb4, 0x42d4f4,
                                                         0xf032e6, 0xffe119, 0x469990, 0x000075, 0xaaffc3, 0x800000};
constexpr std::uint32_t kBorderColour = 0x1b1e24;
constexpr std::uint32_t kBodyColour = 0x000000;

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  void set(int x, int y, std::uint32_t c) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    std::uint8_t* p = &rgb[3 * (static_cast<std::size_t>(y) * width + x)];
    p[0] = static_cast<std::uint8_t>(c >> 16);
    p[1] = static_cast<std::uint8_t>(c >> 8);
    p[2] = static_cast<std::uint8_t>(c);
  }
};

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) out.push_back(static_cast<std::uint8_t>(v >> s));
}

// One PNG chunk: length, type, data, CRC-32 of type and data.
void put_chunk(std::vector<std::uint8_t>& out, const char type[4], const std::vector<std::uint8_t>& data) {
  put_u32(out, static_cast<std::uint32_t>(data.size()));
  const std::size_t type_at = out.size();
  out.insert(out.end(), type, type + 4);
  out.insert(out.end(), data.begin(), data.end());
  const uLong crc = crc32(0L, out.data() + type_at, static_cast<uInt>(out.size() - type_at));
  put_u32(out, static_cast<std::uint32_t>(crc));
}

std::vector<std::uint8_t> encode_png(const Image& img) {
  std::vector<std::uint8_t> raw;  // each row: filter byte 0 (none), then RGB
  raw.reserve(static_cast<std::size_t>(img.height) * (1 + 3 * static_cast<std::size_t>(img.width)));
  for (int y = 0; y < img.height; ++y) {
    raw.push_back(0);
    const auto* row = &img.rgb[3 * static_cast<std::size_t>(y) * img.width];
    raw.insert(raw.end(), row, row + 3 * static_cast<std::size_t>(img.width));
  }
  uLongf packed_size = compressBound(static_cast<uLong>(raw.size()));
  std::vector<std::uint8_t> packed(packed_size);
  if (compress2(packed.data(), &packed_size, raw.data(), static_cast<uLong>(raw.size()), 6) != Z_OK)
    throw std::runtime_error("zlib could not compress the picture");
  packed.resize(packed_size);
  std::vector<std::uint8_t> png = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  std::vector<std::uint8_t> ihdr;
  put_u32(ihdr, static_cast<std::uint32_t>(img.width));
  put_u32(ihdr, static_cast<std::uint32_t>(img.height));
  ihdr.insert(ihdr.end(), {8, 2, 0, 0, 0});  // 8 bits, RGB, deflate, filter 0, no interlace
  put_chunk(png, "IHDR", ihdr);
  put_chunk(png, "IDAT", packed);
  put_chunk(png, "IEND", {});
  return png;
}

}  // namespace

int write_partition_png(const std::string& path, const TerritoryMap& map, const Scene& scene) {
  const CellBox& box = map.box();
  const UniformGrid& grid = map.grid();
  const int nx = static_cast<int>(box.extent(0)), ny = static_cast<int>(box.extent(1)),
            nz = static_cast<int>(box.extent(2));
  // The layer with most dynamic bodies (clamped into the box, as the map does).
  std::vector<std::int64_t> per_layer(static_cast<std::size_t>(ny), 0);
  for (const Body& b : scene.bodies)
    if (!b.is_static) ++per_layer[static_cast<std::size_t>(box.clamp(grid.cell_of(b.position)).y - box.lo.y)];
  const int layer = static_cast<int>(std::max_element(per_layer.begin(), per_layer.end()) - per_layer.begin());

  const int scale = std::max(1, kPartitionPngMaxPixels / std::max(nx, nz));
  Image img;
  img.width = nx * scale;
  img.height = nz * scale;
  img.rgb.assign(3 * static_cast<std::size_t>(img.width) * img.height, 0);
  auto owner_at = [&](int x, int z) { return map.owner(CellCoord{box.lo.x + x, box.lo.y + layer, box.lo.z + z}); };
  for (int x = 0; x < nx; ++x)
    for (int z = 0; z < nz; ++z) {
      const WorldId w = owner_at(x, z);
      const std::uint32_t colour = kWorldColours[static_cast<std::size_t>(w) % kWorldColours.size()];
      for (int px = 0; px < scale; ++px)
        for (int pz = 0; pz < scale; ++pz) {
          const bool left = px == 0 && x > 0 && owner_at(x - 1, z) != w;
          const bool top = pz == 0 && z > 0 && owner_at(x, z - 1) != w;
          img.set(x * scale + px, z * scale + pz, left || top ? kBorderColour : colour);
        }
    }
  const double cell = grid.cell_size();
  for (const Body& b : scene.bodies) {
    if (b.is_static) continue;
    const double fx = (b.position.x() - (grid.origin().x() + box.lo.x * cell)) / cell * scale;
    const double fz = (b.position.z() - (grid.origin().z() + box.lo.z * cell)) / cell * scale;
    const int cx = static_cast<int>(fx), cz = static_cast<int>(fz);
    for (int dx = -1; dx <= 0; ++dx)
      for (int dz = -1; dz <= 0; ++dz) img.set(cx + dx, cz + dz, kBodyColour);
  }
  const std::vector<std::uint8_t> png = encode_png(img);
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  out.close();
  if (!out) throw std::runtime_error("soda partition: cannot write the picture '" + path + "'");
  return box.lo.y + layer;
}

}  // namespace soda::cli
