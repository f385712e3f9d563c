// The frame server and its in-memory source (docs/viewer.md): the wire
// format, the source, the HTTP endpoints on 127.0.0.1. Not labelled
// concurrency: httplib's threads live in Debian's uninstrumented
// libcpp-httplib, which ThreadSanitizer cannot follow (live_source_test.cpp
// is the concurrency test).
#include <cstring>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "record.h"
#include "soda/scene/registry.h"
#include "soda/viewer/frame_codec.h"
#include "soda/viewer/frame_server.h"

// After Eigen (through the SODA headers): a macro of the headers httplib
// pulls in breaks Eigen's templates when Eigen comes second.
#include <httplib.h>

namespace soda {
namespace {

Scene small_scene(int n = 60) {
  SceneParams p;
  p.n = n;
  Scene s = make_scene("falling-cubes", p);
  return s;
}

template <class T>
T read_at(const std::string& bytes, std::size_t offset) {
  T v;
  std::memcpy(&v, bytes.data() + offset, sizeof v);
  return v;
}

TEST(FrameCodec, BinaryLayoutIsTheDocumentedOne) {
  replay::ViewFrame f;
  f.step = 42;
  f.position = {1, 2, 3, 4, 5, 6};
  f.orientation = {0, 0, 0, 1, 0, 1, 0, 0};
  f.sleeping = {0, 1};
  f.owner = {3, 1};
  f.cell_owner = {0, 1, 2};
  f.world_busy_ms = {0.5f};
  f.state_hash = 0x0123456789abcdefULL;
  const std::string b = viewer::frame_binary(f, true);
  ASSERT_EQ(b.size(), viewer::kFrameHeaderBytes + 6 * 4 + 8 * 4 + 1 * 4 + 2 * 2 + 3 * 2 + 2);
  EXPECT_EQ(b.substr(0, 4), "SVF1");
  EXPECT_EQ(read_at<std::uint32_t>(b, 4), viewer::kFrameHasHash | viewer::kFrameFinished);
  EXPECT_EQ(read_at<std::int64_t>(b, 8), 42);
  EXPECT_EQ(read_at<std::uint32_t>(b, 16), 2u);
  EXPECT_EQ(read_at<std::uint32_t>(b, 20), 1u);
  EXPECT_EQ(read_at<std::uint32_t>(b, 24), 3u);
  EXPECT_EQ(read_at<std::uint64_t>(b, 32), 0x0123456789abcdefULL);
  EXPECT_EQ(read_at<float>(b, 40 + 5 * 4), 6.0f);                    // position[5]
  EXPECT_EQ(read_at<float>(b, 40 + 24 + 5 * 4), 1.0f);               // orientation[5]
  EXPECT_EQ(read_at<float>(b, 40 + 24 + 32), 0.5f);                  // world_busy_ms[0]
  EXPECT_EQ(read_at<std::uint16_t>(b, 40 + 24 + 32 + 4), 3);         // owner[0]
  EXPECT_EQ(read_at<std::uint16_t>(b, 40 + 24 + 32 + 4 + 4 + 4), 2);  // cell_owner[2]
  EXPECT_EQ(static_cast<int>(b.back()), 1);                          // sleeping[1]
  f.sleeping.pop_back();
  EXPECT_THROW(viewer::frame_binary(f, false), std::invalid_argument);
}

// A frame whose bodies are not the header's carries their ids right after
// the header (flag 4), then the arrays as before.
TEST(FrameCodec, IdsFollowTheHeaderWhenBodiesCameOrWent) {
  replay::ViewFrame f;
  f.step = 7;
  f.ids = std::vector<BodyId>{3, 100000};
  f.position = {1, 2, 3, 4, 5, 6};
  f.orientation = {0, 0, 0, 1, 0, 1, 0, 0};
  f.sleeping = {0, 1};
  f.owner = {1, 0};
  const std::string b = viewer::frame_binary(f, false);
  ASSERT_EQ(b.size(), viewer::kFrameHeaderBytes + 2 * 4 + 6 * 4 + 8 * 4 + 2 * 2 + 2);
  EXPECT_EQ(read_at<std::uint32_t>(b, 4), viewer::kFrameHasIds);
  EXPECT_EQ(read_at<std::uint32_t>(b, 16), 2u);
  EXPECT_EQ(read_at<std::uint32_t>(b, 40), 3u);
  EXPECT_EQ(read_at<std::uint32_t>(b, 44), 100000u);
  EXPECT_EQ(read_at<float>(b, 48 + 5 * 4), 6.0f);  // position[5]
  EXPECT_EQ(viewer::frame_json(f, false)["ids"], (nlohmann::json{3, 100000}));
  f.ids->pop_back();
  EXPECT_THROW(viewer::frame_binary(f, false), std::invalid_argument);  // ids for another count
  f.ids.reset();
  EXPECT_EQ(read_at<std::uint32_t>(viewer::frame_binary(f, false), 4), 0u);
  EXPECT_TRUE(viewer::frame_json(f, false)["ids"].is_null());
}

TEST(MemoryFrameSource, ServesNewestAndExactFramesWithTheMapInForce) {
  const test::Recording rec = test::record_frames(small_scene(), 2, 20);
  viewer::MemoryFrameSource& s = *rec.source;
  EXPECT_EQ(s.step_range(), (std::pair<std::int64_t, std::int64_t>{0, 20}));
  EXPECT_TRUE(s.finished());
  auto newest = s.newest_after(-1);
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->step, 20);
  ASSERT_TRUE(newest->state_hash);
  EXPECT_EQ(*newest->state_hash, rec.state_hash);
  EXPECT_FALSE(s.newest_after(20));
  auto mid = s.frame_at(7);
  ASSERT_TRUE(mid);
  EXPECT_EQ(mid->step, 7);
  EXPECT_EQ(mid->cell_owner.size(), static_cast<std::size_t>(s.header().box.count()));
  EXPECT_EQ(mid->owner.size(), s.header().dynamic_count());
  EXPECT_FALSE(s.frame_at(21));
  replay::ViewFrame old = *mid;
  EXPECT_THROW(s.add(old), std::invalid_argument);  // step 7 after 20
  old.step = 99;
  old.owner.pop_back();
  EXPECT_THROW(s.add(old), std::invalid_argument);  // owner too short
}

TEST(FrameServer, AnswersOnLoopbackWithHeaderRangeFramesAndFiles) {
  const test::Recording rec = test::record_frames(small_scene(), 2, 10);
  viewer::FrameServer server(rec.source);
  const int port = server.start();
  ASSERT_GT(port, 0);
  EXPECT_EQ(server.url(), "http://127.0.0.1:" + std::to_string(port) + "/");
  httplib::Client client("127.0.0.1", port);

  auto header = client.Get("/header");
  ASSERT_TRUE(header);
  ASSERT_EQ(header->status, 200);
  const nlohmann::json h = nlohmann::json::parse(header->body);
  EXPECT_EQ(h["format"], "soda-view-header");
  EXPECT_EQ(h["territories"], 2);
  EXPECT_EQ(h["dynamic_count"], rec.source->header().dynamic_count());
  EXPECT_EQ(h["bodies"].size(), rec.source->header().bodies.size());
  EXPECT_EQ(h["bodies"][1]["shape"]["kind"], "box");

  auto range = client.Get("/range");
  ASSERT_TRUE(range);
  EXPECT_EQ(nlohmann::json::parse(range->body), (nlohmann::json{{"first", 0}, {"last", 10}, {"finished", true}}));

  auto newest = client.Get("/frame?after=-1");
  ASSERT_TRUE(newest);
  ASSERT_EQ(newest->status, 200);
  EXPECT_EQ(newest->body.substr(0, 4), "SVF1");
  EXPECT_EQ(read_at<std::int64_t>(newest->body, 8), 10);
  EXPECT_EQ(read_at<std::uint32_t>(newest->body, 4), viewer::kFrameHasHash | viewer::kFrameFinished);
  EXPECT_EQ(read_at<std::uint64_t>(newest->body, 32), rec.state_hash);

  auto json = client.Get("/frame?at=3&format=json");
  ASSERT_TRUE(json);
  ASSERT_EQ(json->status, 200);
  const nlohmann::json f = nlohmann::json::parse(json->body);
  EXPECT_EQ(f["step"], 3);
  EXPECT_TRUE(f["state_hash"].is_null());
  EXPECT_FALSE(f["finished"]);

  EXPECT_EQ(client.Get("/frame?after=10")->status, 204);
  EXPECT_EQ(client.Get("/frame?at=11")->status, 404);
  EXPECT_EQ(client.Get("/frame?at=x1")->status, 400);
  EXPECT_EQ(client.Get("/index.html")->status, 200);
  EXPECT_EQ(client.Get("/main.js")->status, 200);
  EXPECT_EQ(client.Get("/three/build/three.module.js")->status, 200);
  server.stop();
  server.stop();  // idempotent
}

// /bodies describes the bodies frames hold that the header lacks; a frame
// holding them carries their ids.
TEST(FrameServer, DescribesBodiesAddedDuringTheRun) {
  const Scene scene = small_scene(4);
  const test::Recording rec = test::record_frames(scene, 1, 2);
  auto source = std::make_shared<viewer::MemoryFrameSource>(rec.source->header());
  replay::ViewFrame f = *rec.source->frame_at(2);
  f.step = 3;  // body 2 removed, 100000 added
  f.ids = std::vector<BodyId>{1, 3, 4, 100000};
  f.state_hash.reset();
  f.position[3 * 1] = 7.f;
  f.owner.assign(4, 0);
  source->add(*rec.source->frame_at(0));
  source->add(f);
  replay::ViewFrame bad = f;
  bad.step = 4;
  bad.ids = std::vector<BodyId>{1, 3, 100000};  // three bodies, arrays for four
  EXPECT_THROW(source->add(bad), std::invalid_argument);
  replay::ViewBody plank;
  plank.id = 100000;
  plank.shape = Shape::box(Vec3(2, 0.2, 0.5));
  plank.position = Vec3(0, 12, 0);
  source->describe(plank);
  viewer::FrameServer server(source);
  httplib::Client client("127.0.0.1", server.start());
  auto bodies = client.Get("/bodies?ids=100000,2,555");
  ASSERT_TRUE(bodies);
  ASSERT_EQ(bodies->status, 200);
  const nlohmann::json j = nlohmann::json::parse(bodies->body);
  ASSERT_EQ(j["bodies"].size(), 2u);
  EXPECT_EQ(j["bodies"][0]["id"], 100000);
  EXPECT_EQ(j["bodies"][0]["shape"]["kind"], "box");
  EXPECT_EQ(j["bodies"][0]["shape"]["half_extents"], (nlohmann::json{2.0, 0.2, 0.5}));
  EXPECT_EQ(j["bodies"][1]["id"], 2);  // a header body
  EXPECT_EQ(j["unknown"], (nlohmann::json{555}));
  EXPECT_EQ(client.Get("/bodies?ids=1,x")->status, 400);
  EXPECT_EQ(client.Get("/bodies?ids=-1")->status, 400);
  EXPECT_EQ(nlohmann::json::parse(client.Get("/bodies")->body)["bodies"].size(), 0u);
  auto frame = client.Get("/frame?at=3");
  ASSERT_TRUE(frame);
  ASSERT_EQ(frame->status, 200);
  EXPECT_EQ(read_at<std::uint32_t>(frame->body, 4) & viewer::kFrameHasIds, viewer::kFrameHasIds);
  EXPECT_EQ(read_at<std::uint32_t>(frame->body, 40 + 3 * 4), 100000u);  // ids[3]
  EXPECT_EQ(read_at<std::uint32_t>(client.Get("/frame?at=0")->body, 4) & viewer::kFrameHasIds, 0u);
  server.stop();
}

TEST(FrameServer, RefusesMissingFilesAndABusyPort) {
  auto source = std::make_shared<viewer::MemoryFrameSource>(replay::ViewHeader{});
  EXPECT_THROW(viewer::FrameServer(source, {.port = 0, .web_dir = "/nonexistent", .three_dir = ""}),
               std::invalid_argument);
  viewer::FrameServer a(source);
  const int port = a.start();
  viewer::FrameServer b(source, {.port = port, .web_dir = "", .three_dir = ""});
  EXPECT_THROW(b.start(), std::runtime_error);
}

}  // namespace
}  // namespace soda
