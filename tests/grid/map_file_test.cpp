// Territory-map files: format, round trip, loading through make_partition,
// and clear errors naming the file and the line or field.
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "grid/grid_test_util.h"
#include "soda/grid/map_file.h"
#include "soda/grid/partition.h"

namespace soda {
namespace {

using test::expect_grid_error;

// A temporary file removed at scope exit.
struct TempFile {
  std::filesystem::path path;
  explicit TempFile(const std::string& text) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    path = std::filesystem::temp_directory_path() /
           ("soda_grid_" + std::string(info->name()) + "_" + std::to_string(::getpid()) + ".map");
    std::ofstream(path) << text;
  }
  ~TempFile() { std::filesystem::remove(path); }
  std::string str() const { return path.string(); }
};

constexpr const char* kSlabs =
    "soda-territory-map 1   # two worlds split at x = 0\n"
    "cell_size 1.0\n"
    "origin 0 0 0\n"
    "box -2 -1 -1 1 1 1\n"
    "worlds 2\n"
    "owners\n"
    "18*0\n"
    "9*1 9*1\n";

Scene scene_with_half(double half) {
  Scene s;
  s.bodies.push_back(test::cube(1, Vec3(0.5, 0.5, 0.5), half));
  return s;
}

TEST(MapFile, OwnersListWithRunLengths) {
  const TerritoryMap map = parse_territory_map(kSlabs, "slabs.map");
  EXPECT_EQ(map.world_count(), 2);
  EXPECT_EQ(map.box(), (CellBox{{-2, -1, -1}, {1, 1, 1}}));
  EXPECT_EQ(map.grid().cell_size(), 1.0);
  EXPECT_EQ(map.owner_of(Vec3(-1e-9, 0, 0)), 0);
  EXPECT_EQ(map.owner_of(Vec3(1e-9, 0, 0)), 1);
}

TEST(MapFile, TheDocumentedExampleParses) {
  const TerritoryMap map = parse_territory_map(
      "soda-territory-map 1          # header: format name and version\n"
      "cell_size 2.0                 # metres\n"
      "origin 0 0 0                  # metres\n"
      "box -2 0 0 1 1 1              # inclusive cell box\n"
      "worlds 2                      # K\n"
      "owners                        # one owner per box cell\n"
      "8*0 8*1                       # N*W repeats W N times\n",
      "docs.map");
  const TerritoryMap planes = parse_territory_map(
      "soda-territory-map 1\ncell_size 2.0\nbox -2 0 0 1 1 1\nworlds 2\nplanes x 0\n", "p.map");
  EXPECT_EQ(map, planes);
  EXPECT_EQ(map.owner_of(Vec3(-1e-9, 1, 1)), 0);
  EXPECT_EQ(map.owner_of(Vec3(1e-9, 1, 1)), 1);
}

TEST(MapFile, PlanesGiveXMajorBlocks) {
  const TerritoryMap map = parse_territory_map(
      "soda-territory-map 1\ncell_size 2\norigin 1 0 0\nbox -2 0 0 1 1 0\nworlds 4\n"
      "planes x 0\nplanes y 1\n",
      "planes.map");
  EXPECT_EQ(map.owner_of(Vec3(1 - 1e-9, 0.5, 0)), 0);  // border x = origin + 0 * 2 = 1
  EXPECT_EQ(map.owner_of(Vec3(1 + 1e-9, 0.5, 0)), 2);
  EXPECT_EQ(map.owner_of(Vec3(0.0, 2.5, 0)), 1);
  EXPECT_EQ(map.owner_of(Vec3(3.0, 2.5, 0)), 3);
}

TEST(MapFile, FormatThenParseRoundTrips) {
  const Scene scene = test::clustered_scene(200, 3);
  GridOptions o;
  o.origin = Vec3(0.1, -0.2, 1.0 / 3.0);
  const TerritoryMap map = make_partition("kmeans", scene, 5, o);
  const std::string text = format_territory_map(map);
  EXPECT_EQ(parse_territory_map(text, "round.map"), map);
  const TempFile file(text);
  EXPECT_EQ(make_partition(file.str(), scene, 5, GridOptions{}), map);
  EXPECT_EQ(make_partition("file:" + file.str(), scene, 5, GridOptions{}), map);
  const TempFile saved("");
  save_territory_map(map, saved.str());
  EXPECT_EQ(load_territory_map(saved.str(), 5), map);
}

TEST(MapFile, ErrorsNameTheFileAndLine) {
  struct Bad {
    std::string text;
    std::vector<std::string> needles;
  };
  const std::string head = "soda-territory-map 1\ncell_size 1\nbox 0 0 0 1 0 0\n";
  const std::vector<Bad> cases = {
      {"", {"'f.map'", "empty"}},
      {"territory 1\n", {"line 1", "header"}},
      {"soda-territory-map 2\n", {"line 1", "unsupported version '2'"}},
      {head + "worlds 2\ncolour red\n", {"line 5", "unknown field 'colour'"}},
      {"soda-territory-map 1\ncell_size abc\n", {"line 2", "'abc' is not a valid number"}},
      {"soda-territory-map 1\ncell_size 1 2\n", {"line 2", "cell_size <metres>"}},
      {"soda-territory-map 1\n\n# note\ncell_size -1\n", {"line 4", "must be > 0"}},
      {head + "box 0 0 0 1 0 0\n", {"line 4", "'box' repeated (first on line 3)"}},
      {"soda-territory-map 1\nbox 3 0 0 1 0 0\n", {"line 2", "lo must be <= hi"}},
      {head + "worlds 2\n", {"exactly one of 'owners' or 'planes'"}},
      {"soda-territory-map 1\ncell_size 1\nworlds 1\nowners 0\n", {"missing field 'box'"}},
      {head + "worlds 2\nowners 0 2\n", {"line 5", "owner 2 is outside 0..1"}},
      {head + "worlds 2\nowners\n0\n", {"line 6", "expected 2 owners", "got 1"}},
      {head + "worlds 2\nowners 0 1 1\n", {"line 5", "more owners than the 2 cells"}},
      {head + "worlds 2\nowners 0*1 1\n", {"line 5", "repeat count"}},
      {head + "worlds 3\nowners 0 1\n", {"line 4", "3 worlds cannot share the 2 cells"}},
      {head + "worlds 2\nplanes x 0\n", {"line 5", "planes must increase strictly"}},
      {"soda-territory-map 1\ncell_size 1\nbox 0 0 0 2 0 0\nworlds 3\nplanes x 1\n",
       {"line 4", "planes make 2 blocks but worlds is 3"}},
      {head + "worlds 2\nplanes w 1\n", {"line 5", "planes x|y|z"}},
      {"soda-territory-map 1\ncell_size 1\nbox 0 0 0 2 0 0\nworlds 2\nowners 0 1 0\n",
       {"world 0 is not connected", "2 separate pieces"}},
      {"soda-territory-map 1\ncell_size 1\nbox 0 0 0 2 0 0\nworlds 3\nowners 0 1 1\n",
       {"world 2 owns no cell"}},
  };
  for (const Bad& bad : cases) {
    SCOPED_TRACE(bad.text);
    std::vector<std::string> needles = bad.needles;
    needles.push_back("territory map 'f.map'");
    try {
      parse_territory_map(bad.text, "f.map");
      ADD_FAILURE() << "expected GridError";
    } catch (const GridError& e) {
      for (const std::string& n : needles)
        EXPECT_NE(std::string(e.what()).find(n), std::string::npos)
            << "message '" << e.what() << "' lacks '" << n << "'";
    }
  }
}

TEST(MapFile, LoadChecksTheSceneAndTheWorldCount) {
  const TempFile file(kSlabs);
  EXPECT_EQ(load_territory_map(file.str(), 2).world_count(), 2);
  expect_grid_error([&] { make_partition(file.str(), scene_with_half(0.25), 3, GridOptions{}); },
                    {file.str(), "field worlds", "2 worlds but 3"});
  // Bodies larger than the file's cells span several of them.
  EXPECT_EQ(make_partition(file.str(), scene_with_half(1.0), 2, GridOptions{}).world_count(), 2);
  expect_grid_error([&] { load_territory_map("/no/such/dir/x.map", 1); },
                    {"cannot open territory map '/no/such/dir/x.map'"});
}

}  // namespace
}  // namespace soda
