// Replay files whose bodies come and go (format version 2): each frame
// holds the bodies alive at its step, added bodies are described once and
// drawn from any frame read at random, a population change is a keyframe,
// runs without inputs cost what they did, and version 1 files still read.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>

#include "replay_test_util.h"
#include "soda/replay/replay_reader.h"
#include "soda/replay/replay_writer.h"

namespace soda::replay {
namespace {

using testing::expect_same;
using testing::TempPath;

std::vector<char> bytes_of(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

bool holds(const ViewFrame& f, BodyId id) {
  return f.ids && std::find(f.ids->begin(), f.ids->end(), id) != f.ids->end();
}

constexpr BodyId kGone = 3;  // the header body removed halfway

TEST(ReplayPopulation, BodiesComeAndGoAtRandomAccess) {
  TempPath file("population");
  const ViewHeader h = testing::make_header(40, 3);
  const std::vector<ViewBody> added = testing::added_bodies();
  const int count = 120;
  const std::vector<ViewFrame> input = testing::make_population_frames(h, added, kGone, count, 5);
  std::vector<ViewFrame> stored;
  std::vector<int> keyframe_at;  // frames the writer made keyframes
  std::size_t keyframes = 0;
  {
    ReplayWriter out(file.path, h, {.keyframe_every = 16, .compression_level = 1});
    for (const ViewBody& b : added) out.describe(b);
    out.describe(added[0]);  // the same description again: ignored
    for (int t = 0; t < count; ++t) {
      const std::size_t before = out.keyframes();
      out.append(input[static_cast<std::size_t>(t)]);
      if (out.keyframes() > before) keyframe_at.push_back(t);
      stored.push_back(out.stored_frame());
    }
    keyframes = out.keyframes();
    out.close();
  }
  // Population changes at frames 40 (1000 comes), 41 (1001), 60 (3 goes),
  // 80 (1000 goes): each a keyframe.
  for (int t : {count / 3, count / 3 + 1, count / 2, 2 * count / 3})
    EXPECT_NE(std::find(keyframe_at.begin(), keyframe_at.end(), t), keyframe_at.end()) << t;
  ReplayReader in(file.path);
  EXPECT_EQ(in.version(), 3u);
  EXPECT_EQ(in.keyframe_count(), keyframes);
  ASSERT_EQ(in.added_bodies().size(), 2u);
  for (std::size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(in.added_bodies()[k].id, added[k].id);
    EXPECT_EQ(in.added_bodies()[k].shape.kind, added[k].shape.kind);
    EXPECT_EQ(in.added_bodies()[k].shape.half_extents, added[k].shape.half_extents);
    EXPECT_EQ(in.added_bodies()[k].shape.radius, added[k].shape.radius);
    EXPECT_EQ(in.added_bodies()[k].shape.height, added[k].shape.height);
    EXPECT_EQ(in.added_bodies()[k].position, added[k].position);
    EXPECT_EQ(in.added_bodies()[k].orientation.coeffs(), added[k].orientation.coeffs());
  }
  EXPECT_EQ(in.body(1001)->shape.kind, ShapeKind::Capsule);
  EXPECT_EQ(in.body(kGone)->id, kGone);  // a header body
  EXPECT_FALSE(in.body(999));
  EXPECT_EQ(in.header().dynamic_count(), 40u);  // the header: the bodies at the start

  // Every frame, forwards, backwards and shuffled: what the writer stored.
  std::vector<std::size_t> walk;
  for (int i = 0; i < count; ++i) walk.push_back(static_cast<std::size_t>(i));
  for (int i = count; i-- > 0;) walk.push_back(static_cast<std::size_t>(i));
  std::vector<std::size_t> shuffled(walk.begin(), walk.begin() + count);
  std::shuffle(shuffled.begin(), shuffled.end(), std::mt19937_64(11));
  walk.insert(walk.end(), shuffled.begin(), shuffled.end());
  for (std::size_t i : walk) {
    const std::optional<ViewFrame> f = in.frame_at(input[i].step);
    ASSERT_TRUE(f) << input[i].step;
    expect_same(*f, stored[i]);
    EXPECT_EQ(f->ids, input[i].ids);  // the ids are stored exactly
  }
  // Each body from its step on, and not after it left.
  for (int t = 0; t < count; ++t) {
    const ViewFrame f = *in.frame_at(input[static_cast<std::size_t>(t)].step);
    const bool header_bodies = !f.ids;
    EXPECT_EQ(header_bodies, t < count / 3) << t;
    EXPECT_EQ(holds(f, 1000), t >= count / 3 && t < 2 * count / 3) << t;
    EXPECT_EQ(holds(f, 1001), t >= count / 3 + 1) << t;
    EXPECT_EQ(header_bodies || holds(f, kGone), t < count / 2) << t;
    EXPECT_EQ(f.sleeping.size(), header_bodies ? 40u : f.ids->size());
  }
}

// A run whose bodies never change costs what it did in version 1: frames
// without ids, one byte a keyframe and four in the index more; naming the
// header's bodies in ids stores the same file.
TEST(ReplayPopulation, FixedBodiesStoreNoIds) {
  TempPath plain("fixed_plain"), named("fixed_named");
  const ViewHeader h = testing::make_header(30, 2);
  const std::vector<ViewFrame> frames = testing::make_frames(h, 50, 3);
  std::vector<BodyId> ids;
  for (const ViewBody& b : h.bodies)
    if (!b.is_static) ids.push_back(b.id);
  std::size_t keyframes = 0;
  {
    ReplayWriter a(plain.path, h, {.keyframe_every = 10});
    ReplayWriter b(named.path, h, {.keyframe_every = 10});
    for (ViewFrame f : frames) {
      a.append(f);
      f.ids = ids;
      b.append(f);
    }
    keyframes = a.keyframes();
  }
  EXPECT_EQ(bytes_of(plain.path), bytes_of(named.path));
  ReplayReader in(plain.path);
  EXPECT_EQ(in.keyframe_count(), keyframes);
  EXPECT_TRUE(in.added_bodies().empty());
  for (std::size_t i = 0; i < in.frame_count(); ++i) EXPECT_FALSE(in.frame_at(in.step_of(i))->ids);
}

TEST(ReplayPopulation, WriterRefusesUndescribedAndMisnamedBodies) {
  TempPath file("population_bad");
  const ViewHeader h = testing::make_header(4, 2);
  const std::vector<ViewBody> added = testing::added_bodies();
  const std::vector<ViewFrame> frames = testing::make_population_frames(h, added, 2, 9, 1);
  ReplayWriter out(file.path, h);
  auto message = [&](const ViewFrame& f) {
    try {
      out.append(f);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  auto describe = [&](const ViewBody& b) {
    try {
      out.describe(b);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  out.append(frames[0]);
  ASSERT_TRUE(frames[3].ids);  // body 1000 came
  EXPECT_NE(message(frames[3]).find("step 9, body 1000: not in the header and never described"), std::string::npos)
      << message(frames[3]);
  ViewFrame f = frames[1];
  f.ids = std::vector<BodyId>{1, 3, 2, 4};
  EXPECT_NE(message(f).find("ids not ascending at body 2"), std::string::npos) << message(f);
  f.ids = std::vector<BodyId>{0, 1, 2, 3};
  EXPECT_NE(message(f).find("body 0: a static body of the header"), std::string::npos) << message(f);
  f = frames[1];
  f.ids = std::vector<BodyId>{1, 2, 3};  // three bodies, arrays for four
  EXPECT_NE(message(f).find("position has 12 values, the frame's 3 dynamic bodies need 9"), std::string::npos)
      << message(f);
  ViewBody wrong = added[0];
  wrong.is_static = true;
  EXPECT_NE(describe(wrong).find("describe body 1000: a static body"), std::string::npos) << describe(wrong);
  wrong = added[0];
  wrong.id = 2;
  EXPECT_NE(describe(wrong).find("describe body 2: the header has a body with that id"), std::string::npos);
  EXPECT_EQ(describe(added[0]), "accepted");
  wrong = added[0];
  wrong.shape = Shape::sphere(1.0);
  EXPECT_NE(describe(wrong).find("described before with another shape"), std::string::npos) << describe(wrong);
  EXPECT_EQ(describe(added[1]), "accepted");
  for (std::size_t i = 1; i < frames.size(); ++i) EXPECT_EQ(message(frames[i]), "accepted") << i;
  out.close();
  ReplayReader in(file.path);
  EXPECT_EQ(in.frame_count(), frames.size());  // the refused frames left no trace
  EXPECT_EQ(in.added_bodies().size(), 2u);
}

// Every body removed (a frame holding none), then the header's bodies again
// (a hand-made sequence: a run never reuses an id): an empty population is
// not "the header's", and the header's again stores no ids.
TEST(ReplayPopulation, NoBodyAtAllAndTheHeadersAgain) {
  TempPath file("population_empty");
  const ViewHeader h = testing::make_header(3, 1);
  std::vector<ViewFrame> frames = testing::make_frames(h, 6, 2);
  ViewFrame& empty = frames[2];
  empty.ids = std::vector<BodyId>{};
  empty.position.clear();
  empty.orientation.clear();
  empty.sleeping.clear();
  empty.owner.clear();
  {
    ReplayWriter out(file.path, h, {.keyframe_every = 100});
    for (const ViewFrame& f : frames) out.append(f);
    EXPECT_EQ(out.keyframes(), 3u);  // the first, the empty one, the header's again
  }
  ReplayReader in(file.path);
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const ViewFrame f = *in.frame_at(frames[i].step);
    EXPECT_EQ(f.ids.has_value(), i == 2) << i;
    EXPECT_EQ(f.sleeping.size(), i == 2 ? 0u : 3u) << i;
  }
}

TEST(ReplayPopulation, VersionOneFilesStillRead) {
  // Recorded by the version 1 writer: soda run --scene falling-cubes --n 30
  // --territories 2 --steps 40 --record version1.replay --record-keyframes 16
  const std::string path = std::string(SODA_REPLAY_TEST_DATA) + "/version1.replay";
  ReplayReader in(path);
  EXPECT_EQ(in.version(), 1u);
  EXPECT_EQ(in.header().scene, "falling-cubes");
  EXPECT_EQ(in.header().dynamic_count(), 30u);
  EXPECT_EQ(in.header().territories, 2);
  EXPECT_EQ(in.frame_count(), 41u);
  EXPECT_EQ(in.keyframe_count(), 3u);
  EXPECT_TRUE(in.added_bodies().empty());
  for (std::size_t i = in.frame_count(); i-- > 0;) {  // backwards: every keyframe and delta
    const ViewFrame f = *in.frame_at(in.step_of(i));
    EXPECT_FALSE(f.ids);
    EXPECT_EQ(f.sleeping.size(), 30u);
    EXPECT_EQ(f.position.size(), 90u);
    EXPECT_FALSE(f.cell_owner.empty());
  }
  const ViewFrame last = *in.frame_at(40);
  ASSERT_TRUE(last.state_hash);
  EXPECT_EQ(*last.state_hash, 0x9137f1653b9cad98ULL);
}

}  // namespace
}  // namespace soda::replay
