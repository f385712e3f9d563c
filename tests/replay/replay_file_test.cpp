// Replay files: what the writer stores reads back exactly, within the
// stated error of the input, in any order of access (keyframes + deltas).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <random>

#include "replay_test_util.h"
#include "soda/replay/replay_reader.h"
#include "soda/replay/replay_writer.h"

namespace soda::replay {
namespace {

using testing::expect_same;
using testing::TempPath;

struct Written {
  std::vector<ViewFrame> input, stored;
  std::vector<ViewFrame> in_force;  // input with cell_owner: the map in force
  std::vector<PositionBox> boxes;
  std::size_t keyframes = 0;
};

Written write_file(const std::string& path, const ViewHeader& h, int count, int keyframe_every) {
  Written w;
  w.input = testing::make_frames(h, count, 42);
  ReplayWriter out(path, h, {.keyframe_every = keyframe_every, .compression_level = 6});
  std::vector<std::uint16_t> map;
  for (const ViewFrame& f : w.input) {
    out.append(f);
    w.stored.push_back(out.stored_frame());
    w.boxes.push_back(out.stored_box());
    if (!f.cell_owner.empty()) map = f.cell_owner;
    w.in_force.push_back(f);
    w.in_force.back().cell_owner = map;
  }
  w.keyframes = out.keyframes();
  out.close();
  EXPECT_EQ(out.bytes(), std::filesystem::file_size(path));
  return w;
}

TEST(ReplayFile, HeaderRoundTripsExactly) {
  TempPath file("header");
  const ViewHeader h = testing::make_header(30, 3);
  write_file(file.path, h, 5, 4);
  ReplayReader in(file.path);
  const ViewHeader& r = in.header();
  EXPECT_EQ(r.scene, h.scene);
  EXPECT_EQ(r.seed, h.seed);
  EXPECT_EQ(r.dt, h.dt);
  EXPECT_EQ(r.territories, h.territories);
  EXPECT_EQ(r.grid.origin(), h.grid.origin());
  EXPECT_EQ(r.grid.cell_size(), h.grid.cell_size());
  EXPECT_EQ(r.box.lo, h.box.lo);
  EXPECT_EQ(r.box.hi, h.box.hi);
  ASSERT_EQ(r.bodies.size(), h.bodies.size());
  for (std::size_t i = 0; i < h.bodies.size(); ++i) {
    EXPECT_EQ(r.bodies[i].id, h.bodies[i].id);
    EXPECT_EQ(r.bodies[i].is_static, h.bodies[i].is_static);
    EXPECT_EQ(r.bodies[i].shape.kind, h.bodies[i].shape.kind);
    EXPECT_EQ(r.bodies[i].shape.half_extents, h.bodies[i].shape.half_extents);
    EXPECT_EQ(r.bodies[i].shape.radius, h.bodies[i].shape.radius);
    EXPECT_EQ(r.bodies[i].position, h.bodies[i].position);
    EXPECT_EQ(r.bodies[i].orientation.coeffs(), h.bodies[i].orientation.coeffs());
  }
  EXPECT_EQ(in.version(), 3u);
  EXPECT_EQ(in.keyframe_every(), 4);
  EXPECT_TRUE(in.finished());
}

TEST(ReplayFile, RandomAccessWalkReadsWhatTheWriterStored) {
  TempPath file("walk");
  const ViewHeader h = testing::make_header(120, 4);
  const int count = 150;
  const Written w = write_file(file.path, h, count, 16);
  // Every 16 frames, plus the one forced when a body left the box.
  EXPECT_GE(w.keyframes, static_cast<std::size_t>((count + 15) / 16 + 1));
  ReplayReader in(file.path);
  ASSERT_EQ(in.frame_count(), static_cast<std::size_t>(count));
  EXPECT_EQ(in.keyframe_count(), w.keyframes);
  EXPECT_EQ(in.step_range(), std::make_pair(w.input.front().step, w.input.back().step));
  // Forwards, backwards, and a shuffled walk (seeks into every segment,
  // backwards within one, forwards across several).
  std::vector<std::size_t> order(count);
  for (int i = 0; i < count; ++i) order[static_cast<std::size_t>(i)] = static_cast<std::size_t>(i);
  std::vector<std::size_t> shuffled = order;
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937_64(3));
  std::vector<std::size_t> walk;
  for (std::size_t i : order) walk.push_back(i);
  for (std::size_t i = order.size(); i-- > 0;) walk.push_back(i);
  for (std::size_t i : shuffled) walk.push_back(i);
  for (std::size_t i : walk) {
    std::optional<ViewFrame> f = in.frame_at(w.input[i].step);
    ASSERT_TRUE(f) << w.input[i].step;
    expect_same(*f, w.stored[i]);
    EXPECT_EQ(in.box_at(w.input[i].step), w.boxes[i]);
  }
  EXPECT_FALSE(in.frame_at(w.input[11].step - 1));  // a step never recorded
  EXPECT_FALSE(in.frame_at(-1));
  ASSERT_TRUE(in.newest_after(0));
  EXPECT_EQ(in.newest_after(0)->step, w.input.back().step);
  EXPECT_FALSE(in.newest_after(w.input.back().step));
}

TEST(ReplayFile, StoredValuesAreTheInputWithinTheStatedError) {
  TempPath file("bound");
  const ViewHeader h = testing::make_header(80, 2);
  const Written w = write_file(file.path, h, 120, 30);
  ReplayReader in(file.path);
  for (std::size_t t = 0; t < w.input.size(); ++t) {
    const ViewFrame& a = w.input[t];
    const ViewFrame f = *in.frame_at(a.step);
    const double bound = position_error_bound(w.boxes[t]);
    EXPECT_LE(bound, in.position_error_bound());
    for (std::size_t i = 0; i < a.position.size(); ++i)
      ASSERT_LE(std::fabs(static_cast<double>(f.position[i]) - a.position[i]), bound) << "step " << a.step;
    for (std::size_t i = 0; i < a.sleeping.size(); ++i) {
      double dot = 0;
      for (int c = 0; c < 4; ++c) dot += static_cast<double>(f.orientation[4 * i + c]) * a.orientation[4 * i + c];
      ASSERT_LE(2 * std::acos(std::min(1.0, std::fabs(dot))), kOrientationErrorBound) << "step " << a.step;
    }
    // What is stored losslessly is the input.
    EXPECT_EQ(f.sleeping, a.sleeping);
    EXPECT_EQ(f.owner, a.owner);
    EXPECT_EQ(f.cell_owner, w.in_force[t].cell_owner);
    EXPECT_EQ(f.world_busy_ms, a.world_busy_ms);
    EXPECT_EQ(f.state_hash, a.state_hash);
  }
  EXPECT_TRUE(in.frame_at(w.input.back().step)->state_hash.has_value());
  EXPECT_FALSE(in.frame_at(w.input.front().step)->state_hash.has_value());
}

TEST(ReplayFile, FileWithoutFramesReads) {
  TempPath file("empty");
  const ViewHeader h = testing::make_header(3, 1);
  { ReplayWriter out(file.path, h); }  // closed by the destructor
  ReplayReader in(file.path);
  EXPECT_EQ(in.frame_count(), 0u);
  EXPECT_EQ(in.step_range(), std::make_pair(std::int64_t{0}, std::int64_t{-1}));
  EXPECT_FALSE(in.newest_after(-100));
}

TEST(ReplayFile, WriterRefusesBadFramesNamingBodyAndField) {
  TempPath file("bad");
  const ViewHeader h = testing::make_header(4, 2);
  const std::vector<ViewFrame> frames = testing::make_frames(h, 3, 1);
  ReplayWriter out(file.path, h);
  auto message = [&](ViewFrame f) {
    try {
      out.append(f);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  ViewFrame f = frames[0];
  f.position[3 * 2 + 1] = NAN;
  EXPECT_NE(message(f).find("body 3: position is not finite"), std::string::npos) << message(f);
  f = frames[0];
  f.owner[1] = 2;
  EXPECT_NE(message(f).find("body 2: owner 2 >= territories 2"), std::string::npos) << message(f);
  f = frames[0];
  f.orientation.pop_back();
  EXPECT_NE(message(f).find("orientation has 15 values"), std::string::npos) << message(f);
  f = frames[0];
  f.cell_owner.clear();
  EXPECT_NE(message(f).find("the first frame must carry the map"), std::string::npos) << message(f);
  out.append(frames[0]);
  EXPECT_NE(message(frames[0]).find("step 0 does not follow step 0"), std::string::npos) << message(frames[0]);
  EXPECT_NE(message(frames[0]).find(file.path), std::string::npos);
  out.close();
  EXPECT_THROW(out.append(frames[1]), std::logic_error);
  EXPECT_EQ(ReplayReader(file.path).frame_count(), 1u);  // the refused frames left no trace
}

TEST(ReplayFile, UnwritablePathIsAClearError) {
  const ViewHeader h = testing::make_header(2, 1);
  try {
    ReplayWriter out("/nonexistent-dir/x.replay", h);
    FAIL() << "opened";
  } catch (const ReplayError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-dir/x.replay: cannot open for writing"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace soda::replay
