// Damaged replay files: every kind of damage is a ReplayFormatError naming
// the file and what is wrong, never a crash or another exception.
#include <gtest/gtest.h>

#include <fstream>
#include <iterator>

#include "replay_test_util.h"
#include "soda/replay/replay_reader.h"
#include "soda/replay/replay_writer.h"

namespace soda::replay {
namespace {

using testing::TempPath;

std::vector<char> bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}
void write_bytes(const std::string& path, const std::vector<char>& b) {
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(b.data(), static_cast<std::streamsize>(b.size()));
}

// Opens the file and decodes every frame; the error's message, or "" if
// all of it read.
std::string read_all(const std::string& path) {
  try {
    ReplayReader in(path);
    for (std::size_t i = 0; i < in.frame_count(); ++i) (void)in.frame_at(in.step_of(i));
    return "";
  } catch (const ReplayFormatError& e) {
    EXPECT_EQ(e.path(), path);
    EXPECT_EQ(std::string(e.what()).rfind(path + ": ", 0), 0u) << e.what();
    return e.what();
  }
}

class Damaged : public ::testing::Test {
 protected:
  void SetUp() override {
    // Small (about 1,100 bytes): every byte of it is damaged in turn below.
    // Bodies come and go in it (two described, one removed): every chunk
    // kind is there.
    const ViewHeader h = testing::make_header(4, 2);
    ReplayWriter out(good.path, h, {.keyframe_every = 3});
    for (const ViewBody& b : testing::added_bodies()) out.describe(b);
    for (const ViewFrame& f : testing::make_population_frames(h, testing::added_bodies(), 2, 9, 9)) out.append(f);
    out.close();
    bytes = bytes_of(good.path);
  }
  TempPath good{"good"}, bad{"bad"};
  std::vector<char> bytes;
};

TEST_F(Damaged, TheUndamagedFileReads) { EXPECT_EQ(read_all(good.path), ""); }

TEST_F(Damaged, MissingFile) {
  EXPECT_NE(read_all(bad.path + ".none").find("cannot open: No such file"), std::string::npos);
}

TEST_F(Damaged, WrongMagic) {
  std::vector<char> b = bytes;
  b[0] = 'X';
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path).find("not a replay file"), std::string::npos) << read_all(bad.path);
}

TEST_F(Damaged, WrongVersion) {
  std::vector<char> b = bytes;
  b[8] = 4;
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path).find("replay format version 4, this build reads versions 1 to 3 (a newer writer?)"),
            std::string::npos)
      << read_all(bad.path);
  b[8] = 0;
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path).find("replay format version 0, this build reads versions 1 to 3"), std::string::npos)
      << read_all(bad.path);
  // A version 3 file read as version 2 or 1: its bodies or keyframes do not
  // decode.
  b[8] = 2;
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path), "");
  b[8] = 1;
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path), "");
}

TEST_F(Damaged, EveryTruncationIsNamed) {
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    write_bytes(bad.path, std::vector<char>(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)));
    const std::string what = read_all(bad.path);
    ASSERT_NE(what, "") << "cut at " << n << " bytes read without error";
    EXPECT_TRUE(what.find("truncated") != std::string::npos || what.find("not a replay file") != std::string::npos)
        << what;
  }
}

// Offset of the first chunk tagged `tag` (walking the chunks from the file
// header: tag, raw size, stored size, CRC, stored bytes).
std::size_t chunk_at(const std::vector<char>& b, const char (&tag)[5]) {
  std::size_t at = 16;
  auto u32 = [&](std::size_t i) {
    std::uint32_t v = 0;
    for (int k = 3; k >= 0; --k) v = v << 8 | static_cast<unsigned char>(b[i + static_cast<std::size_t>(k)]);
    return v;
  };
  while (at + 16 <= b.size()) {
    if (std::string(&b[at], 4) == tag) return at;
    at += 16 + u32(at + 8);
  }
  ADD_FAILURE() << "no " << tag << " chunk";
  return 0;
}

TEST_F(Damaged, AFlippedByteInAFrameIsAChecksumError) {
  std::vector<char> b = bytes;
  b[chunk_at(b, "DELT") + 20] ^= 0x10;  // inside the first delta's stored bytes
  write_bytes(bad.path, b);
  const std::string what = read_all(bad.path);
  EXPECT_NE(what.find("checksum mismatch"), std::string::npos) << what;
  EXPECT_NE(what.find("of step"), std::string::npos) << what;  // names the frame
  b = bytes;
  b[chunk_at(b, "BODS") + 20] ^= 0x10;
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path).find("the added bodies at byte"), std::string::npos) << read_all(bad.path);
}

// Every single-byte change anywhere: an error or (a byte that decodes
// alike, e.g. a padding-free float in the header) a file that reads; never
// a crash or another exception type.
TEST_F(Damaged, EveryFlippedByteIsAnErrorOrHarmless) {
  int errors = 0;
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    std::vector<char> b = bytes;
    b[i] = static_cast<char>(b[i] ^ 0x5A);
    write_bytes(bad.path, b);
    errors += read_all(bad.path).empty() ? 0 : 1;
  }
  // Only the file header's reserved bytes are not covered by a check... and
  // they are checked too: every byte counts.
  EXPECT_EQ(errors, static_cast<int>(bytes.size()));
}

}  // namespace
}  // namespace soda::replay
