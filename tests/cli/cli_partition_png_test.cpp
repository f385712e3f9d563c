// `soda partition --png FILE`: the picture is a valid PNG whose squares are
// the worlds' colours where the map puts them.
#include <zlib.h>

#include <cstdint>
#include <fstream>
#include <iterator>
#include <regex>
#include <string>
#include <vector>

#include "cli_test_util.h"

namespace soda_cli_test {
namespace {

std::uint32_t be32(const std::vector<unsigned char>& b, std::size_t at) {
  return (std::uint32_t{b[at]} << 24) | (std::uint32_t{b[at + 1]} << 16) | (std::uint32_t{b[at + 2]} << 8) |
         std::uint32_t{b[at + 3]};
}

struct Picture {
  std::uint32_t width = 0, height = 0;
  std::vector<unsigned char> rows;  // filter byte + RGB per row
  std::uint32_t pixel(std::uint32_t x, std::uint32_t y) const {
    const unsigned char* p = &rows[y * (1 + 3 * width) + 1 + 3 * x];
    return (std::uint32_t{p[0]} << 16) | (std::uint32_t{p[1]} << 8) | p[2];
  }
};

// Reads an 8-bit RGB PNG with one IDAT chunk (what the writer makes).
Picture read_png(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  const std::vector<unsigned char> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Picture pic;
  EXPECT_GE(b.size(), 33u);
  if (b.size() < 33) return pic;
  EXPECT_EQ(std::vector<unsigned char>(b.begin(), b.begin() + 8),
            (std::vector<unsigned char>{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'}));
  std::vector<unsigned char> idat;
  for (std::size_t at = 8; at + 12 <= b.size();) {
    const std::uint32_t len = be32(b, at);
    const std::string type(b.begin() + at + 4, b.begin() + at + 8);
    const uLong crc = crc32(0L, b.data() + at + 4, len + 4);
    EXPECT_EQ(crc, be32(b, at + 8 + len)) << type << " chunk's CRC";
    if (type == "IHDR") {
      pic.width = be32(b, at + 8);
      pic.height = be32(b, at + 12);
      EXPECT_EQ(b[at + 16], 8);  // bits per channel
      EXPECT_EQ(b[at + 17], 2);  // RGB
    }
    if (type == "IDAT") idat.assign(b.begin() + at + 8, b.begin() + at + 8 + len);
    at += 12 + len;
  }
  uLongf size = static_cast<uLongf>(pic.height) * (1 + 3 * pic.width);
  pic.rows.resize(size);
  EXPECT_EQ(uncompress(pic.rows.data(), &size, idat.data(), static_cast<uLong>(idat.size())), Z_OK);
  EXPECT_EQ(size, pic.rows.size());
  return pic;
}

// WORLD_COLOURS[w] of the viewer's palette (viewer/web/palette.js), which
// the picture must use: partition_png.cpp keeps a copy, and this reads the
// original, so the two cannot drift apart.
std::uint32_t viewer_world_colour(int w) {
  std::ifstream in(SODA_PALETTE_JS);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::smatch list;
  EXPECT_TRUE(std::regex_search(text, list, std::regex(R"(WORLD_COLOURS = \[([^\]]*)\])"))) << SODA_PALETTE_JS;
  const std::string body = list[1];
  std::vector<std::uint32_t> colours;
  const std::regex hex("0x([0-9a-fA-F]{6})");
  for (auto it = std::sregex_iterator(body.begin(), body.end(), hex); it != std::sregex_iterator(); ++it)
    colours.push_back(static_cast<std::uint32_t>(std::stoul((*it)[1], nullptr, 16)));
  EXPECT_GT(colours.size(), static_cast<std::size_t>(w));
  return colours.size() > static_cast<std::size_t>(w) ? colours[static_cast<std::size_t>(w)] : 0;
}

TEST_F(CliTest, PartitionPngShowsEachWorldWhereTheMapPutsIt) {
  const std::string file = (dir_ / "map.png").string();
  const Outcome o =
      run_cli("partition --scene falling-cubes --n 200 --territories 2 --partition grid:2x1x1 --png " + file);
  ASSERT_EQ(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("wrote " + file), std::string::npos) << o.output;
  const Picture pic = read_png(file);
  ASSERT_GT(pic.width, 100u);
  ASSERT_GT(pic.height, 100u);
  ASSERT_EQ(pic.rows.size(), static_cast<std::size_t>(pic.height) * (1 + 3 * pic.width));
  // grid:2x1x1 cuts along x: world 0 (red in the viewer's palette) on the
  // left, world 1 (green) on the right; bodies are black dots.
  const std::uint32_t kRed = viewer_world_colour(0), kGreen = viewer_world_colour(1);
  ASSERT_EQ(kRed, 0xe6194bu);
  ASSERT_EQ(kGreen, 0x3cb44bu);
  std::size_t red_left = 0, green_right = 0, wrong_side = 0;
  for (std::uint32_t y = 0; y < pic.height; ++y)
    for (std::uint32_t x = 0; x < pic.width; ++x) {
      const std::uint32_t c = pic.pixel(x, y);
      const bool left = x < pic.width / 4, right = x >= 3 * pic.width / 4;
      red_left += left && c == kRed;
      green_right += right && c == kGreen;
      wrong_side += (left && c == kGreen) || (right && c == kRed);
    }
  EXPECT_GT(red_left, pic.width * pic.height / 8) << "world 0 not drawn on the left";
  EXPECT_GT(green_right, pic.width * pic.height / 8) << "world 1 not drawn on the right";
  EXPECT_EQ(wrong_side, 0u);
}

TEST_F(CliTest, PartitionPngToAnUnwritablePathIsAClearError) {
  const Outcome o = run_cli("partition --scene falling-cubes --n 50 --territories 2 --png /nonexistent-dir/map.png");
  EXPECT_NE(o.exit_code, 0) << o.output;
  EXPECT_NE(o.output.find("cannot write the picture '/nonexistent-dir/map.png'"), std::string::npos) << o.output;
}

}  // namespace
}  // namespace soda_cli_test
