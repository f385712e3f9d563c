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
    // Small (about 700 bytes): every byte of it is damaged in turn below.
    const ViewHeader h = testing::make_header(4, 2);
    ReplayWriter out(good.path, h, {.keyframe_every = 3});
    for (const ViewFrame& f : testing::make_frames(h, 7, 9)) out.append(f);
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
  b[8] = 2;
  write_bytes(bad.path, b);
  EXPECT_NE(read_all(bad.path).find("replay format version 2, this build reads version 1"), std::string::npos)
      << read_all(bad.path);
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

TEST_F(Damaged, AFlippedByteInAFrameIsAChecksumError) {
  std::vector<char> b = bytes;
  b[b.size() / 2] ^= 0x10;
  write_bytes(bad.path, b);
  const std::string what = read_all(bad.path);
  EXPECT_NE(what.find("checksum mismatch"), std::string::npos) << what;
  EXPECT_NE(what.find("of step"), std::string::npos) << what;  // names the frame
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
