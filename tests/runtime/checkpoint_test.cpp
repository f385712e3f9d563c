// Checkpoints on disk (docs/checkpoints.md) and input logs: a Simulation
// saved at step s on 2 speculating territories, with inputs before s
// (a body added, one removed, a velocity set) and after it (queued in the
// file, and one given after the save), resumed from the file alone with
// 1, 4 and 8 territories on other schedules, reaches the uninterrupted
// run's hash at s + n; truncated, damaged and foreign files are refused with
// a CheckpointError naming the file and the problem; the input log of a run
// replays to its hash. Label "concurrency" (ThreadSanitizer in CI).
#include <gtest/gtest.h>

#include <unistd.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "runtime/simulation_test_util.h"
#include "soda/runtime/checkpoint.h"
#include "soda/scene/input_file.h"
#include "soda/worlds/canonical_world.h"

namespace soda {
namespace {

constexpr int kSaveAt = 60;
constexpr int kSteps = 150;

using test::first_dynamic;
using test::new_cube;
using test::unused_id;

std::string scratch(const std::string& name) {
  return (std::filesystem::temp_directory_path() / ("soda_ckpt_" + std::to_string(::getpid()) + "_" + name)).string();
}

std::vector<std::uint8_t> file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), {});
}

void put_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(bytes.data()),
                                              static_cast<std::streamsize>(bytes.size()));
}

struct Ids {
  BodyId added = 0, late = 0, removed = 0, pushed = 0, gone_after = 0;
};

// The inputs given before the run: before the save (add at 20, removal at
// 40, a velocity at 50) and after it (queued in the checkpoint: an impulse
// at 100 on the added body, a removal at 120).
Ids give_inputs(Simulation& sim, const Scene& s) {
  Ids ids;
  ids.added = unused_id(s);
  ids.late = ids.added + 1;
  ids.removed = first_dynamic(s);
  ids.pushed = ids.removed + 1;
  ids.gone_after = ids.removed + 2;
  sim.add_body(sim.time_of(20), new_cube(ids.added, Vec3(0.2, 10, -0.1)));
  sim.remove_body(sim.time_of(40), ids.removed);
  sim.set_velocity(sim.time_of(50), ids.pushed, Vec3(2, 5, 0), Vec3(0, 1, 0));
  sim.apply_impulse(sim.time_of(100), ids.added, Vec3(1, 6, 0));
  sim.remove_body(sim.time_of(120), ids.gone_after);
  return ids;
}

// The input given after the save (to the uninterrupted run and to each
// resumed one): a body added at 130.
void give_late_input(Simulation& sim, const Ids& ids) {
  sim.add_body(sim.time_of(130), new_cube(ids.late, Vec3(-0.3, 12, 0.2)));
}

SimulationConfig speculating(int territories) {
  SimulationConfig c{.territories = territories, .buffer_capacity = 16};
  c.runtime.anticipation = 8;
  return c;
}

struct Saved {
  std::string path;
  std::uint64_t uninterrupted = 0;
  std::uint64_t one_world = 0;
  Ids ids;
};

// Saves at kSaveAt on 2 speculating territories, goes on to kSteps; the
// same inputs on one territory without a save for the one-world hash.
const Saved& saved() {
  static const Saved out = [] {
    Saved o;
    const Scene s = test::scene("cube-pile", 150);
    o.path = scratch("saved.ckpt");
    Simulation a(s, speculating(2));
    o.ids = give_inputs(a, s);
    EXPECT_TRUE(a.advance_to(a.time_of(kSaveAt)));
    EXPECT_EQ(a.save(o.path), kSaveAt);
    give_late_input(a, o.ids);
    EXPECT_TRUE(a.advance_to(a.time_of(kSteps)));
    o.uninterrupted = a.state_hash();
    Simulation one(s, SimulationConfig{.threads = 1});
    give_inputs(one, s);
    give_late_input(one, o.ids);
    EXPECT_TRUE(one.advance_to(one.time_of(kSteps)));
    o.one_world = one.state_hash();
    return o;
  }();
  return out;
}

struct Case {
  int territories;
  int threads;  // 0: a thread per world
  int anticipation;
  const char* partition;
};

class CheckpointResume : public ::testing::TestWithParam<Case> {};

TEST_P(CheckpointResume, GoesOnToTheUninterruptedHash) {
  const Case c = GetParam();
  const Saved& s = saved();
  EXPECT_EQ(hash_hex(s.uninterrupted), hash_hex(s.one_world));
  const CheckpointHeader h = checkpoint_header(file_bytes(s.path), s.path);
  EXPECT_EQ(h.step, kSaveAt);
  EXPECT_EQ(h.scalar_bytes, sizeof(btScalar));
  EXPECT_EQ(h.inputs, 2u);       // the impulse at 100, the removal at 120
  EXPECT_EQ(h.retired_ids, 1u);  // removed at 40

  SimulationConfig config{.territories = c.territories, .partition = c.partition, .threads = c.threads,
                          .buffer_capacity = 16};
  config.runtime.anticipation = c.anticipation;
  Simulation b = Simulation::resume(s.path, config);  // only the file
  EXPECT_EQ(b.steps_done(), kSaveAt);
  EXPECT_EQ(b.world_count(), c.territories);
  give_late_input(b, s.ids);
  ASSERT_TRUE(b.advance_to(b.time_of(kSteps)));
  const std::uint64_t resumed = b.state_hash();
  std::printf("[ cube-pile 150 + inputs, saved at %d on K 2 anticipation 8: %llu bodies, %llu manifolds, %u queued "
              "inputs, %llu bytes ] uninterrupted %s, one world %s, resumed on K %d (%s) threads %d anticipation %d: "
              "%s at step %d\n",
              kSaveAt, static_cast<unsigned long long>(h.bodies), static_cast<unsigned long long>(h.manifolds),
              h.inputs, static_cast<unsigned long long>(file_bytes(s.path).size()), hash_hex(s.uninterrupted).c_str(),
              hash_hex(s.one_world).c_str(), c.territories, c.partition, c.threads, c.anticipation,
              hash_hex(resumed).c_str(), kSteps);
  EXPECT_EQ(hash_hex(resumed), hash_hex(s.uninterrupted));
  // The removed body's id stays retired after the round trip.
  EXPECT_THROW(b.add_body(b.time_of(kSteps + 1), new_cube(s.ids.removed, Vec3(0, 12, 0))), std::invalid_argument);
}

INSTANTIATE_TEST_SUITE_P(Simulation, CheckpointResume,
                         ::testing::Values(Case{1, 1, 0, "kmeans"}, Case{4, 2, 0, "rcb"}, Case{8, 0, 8, "kmeans"},
                                           Case{4, 1, 4, "grid:4x1x1"}),
                         [](const auto& info) {
                           std::string p = info.param.partition;
                           for (char& ch : p)
                             if (ch == ':') ch = '_';
                           return "K" + std::to_string(info.param.territories) + "_" + p + "_threads" +
                                  std::to_string(info.param.threads) + "_anticipation" +
                                  std::to_string(info.param.anticipation);
                         });

// Encoding is a bit-exact round trip: the decoded snapshot encodes to the
// same bytes.
TEST(Checkpoint, RoundTripIsBitExact) {
  const std::vector<std::uint8_t> bytes = file_bytes(saved().path);
  const SimulationSnapshot snap = decode_checkpoint(bytes, "saved");
  EXPECT_EQ(encode_checkpoint(snap), bytes);
  EXPECT_EQ(snap.state.steps_done, kSaveAt);
  EXPECT_EQ(snap.inputs.size(), 2u);
  // The queued inputs matter: without them the run ends elsewhere.
  SimulationSnapshot without = snap;
  without.inputs.clear();
  Simulation b(without, SimulationConfig{});
  give_late_input(b, saved().ids);
  ASSERT_TRUE(b.advance_to(b.time_of(kSteps)));
  EXPECT_NE(hash_hex(b.state_hash()), hash_hex(saved().uninterrupted));
}

std::uint64_t fnv1a(const std::vector<std::uint8_t>& bytes, std::size_t n) {
  std::uint64_t h = 1469598103934665603ull;
  for (std::size_t i = 0; i < n; ++i) h = (h ^ bytes[i]) * 1099511628211ull;
  return h;
}

// `bytes` with a fresh checksum: a file whose frame is intact.
std::vector<std::uint8_t> resealed(std::vector<std::uint8_t> bytes) {
  const std::uint64_t h = fnv1a(bytes, bytes.size() - 8);
  std::memcpy(bytes.data() + bytes.size() - 8, &h, 8);
  return bytes;
}

// read_checkpoint(path) throws a CheckpointError whose message names the
// file and contains `reason`.
void expect_refused(const std::vector<std::uint8_t>& bytes, const std::string& name, const std::string& reason) {
  const std::string path = scratch(name);
  put_bytes(path, bytes);
  try {
    read_checkpoint(path);
    ADD_FAILURE() << name << ": accepted";
  } catch (const CheckpointError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find(reason), std::string::npos) << name << ": " << what;
    std::printf("  %-16s %s\n", name.c_str(), what.c_str());
  }
  EXPECT_THROW(Simulation::resume(path, {}), CheckpointError) << name;
  std::filesystem::remove(path);
}

TEST(Checkpoint, TruncatedDamagedAndForeignFilesAreRefused) {
  const std::vector<std::uint8_t> good = file_bytes(saved().path);
  ASSERT_GT(good.size(), 1000u);
  for (std::size_t n : {std::size_t{0}, std::size_t{5}, std::size_t{12}, std::size_t{30}, std::size_t{47},
                        std::size_t{56}, good.size() / 2, good.size() - 9, good.size() - 1}) {
    const std::vector<std::uint8_t> cut(good.begin(), good.begin() + static_cast<std::ptrdiff_t>(n));
    expect_refused(cut, "cut-" + std::to_string(n), n == 0 ? "empty" : "truncated");
  }
  std::vector<std::uint8_t> longer = good;
  longer.push_back(0);
  expect_refused(longer, "trailing", "trailing bytes");
  // A flipped bit anywhere past the header's identity: the checksum.
  for (std::size_t at : {std::size_t{20}, std::size_t{60}, good.size() / 3, good.size() - 20, good.size() - 3}) {
    std::vector<std::uint8_t> flipped = good;
    flipped[at] ^= 0x10;
    const bool length_field = at >= 40 && at < 48;
    expect_refused(flipped, "flip-" + std::to_string(at), length_field ? "truncated" : "damaged: the checksum");
  }
  // Another version (any later one keeps magic, version, precision first).
  std::vector<std::uint8_t> later = good;
  later[8] = static_cast<std::uint8_t>(kCheckpointVersion + 1);
  const std::string next = std::to_string(kCheckpointVersion + 1);
  expect_refused(later, "version-" + next,
                 "format version " + next + "; this build reads versions 1 to " + std::to_string(kCheckpointVersion));
  // Another precision: the other build's btScalar size, the frame intact.
  std::vector<std::uint8_t> other = good;
  other[12] = sizeof(btScalar) == 8 ? 4 : 8;
  other = resealed(other);
  expect_refused(other, "precision",
                 sizeof(btScalar) == 8 ? "written by a float-precision build (btScalar of 4 bytes); this is the "
                                         "double-precision build"
                                       : "written by a double-precision build (btScalar of 8 bytes); this is the "
                                         "float-precision build");
  // Not a checkpoint at all.
  const std::string text = R"({"format": "soda-scene", "version": 1})";
  expect_refused(std::vector<std::uint8_t>(text.begin(), text.end()), "json", "not a SODA checkpoint");
  // An intact frame around fields that do not hold: a body count beyond the
  // bytes is read as far as the bytes go, never further.
  std::vector<std::uint8_t> counted = good;
  counted[24] = 0xff, counted[25] = 0xff;
  expect_refused(resealed(counted), "count", " at byte ");
  // A file that is not there.
  try {
    read_checkpoint(scratch("missing.ckpt"));
    ADD_FAILURE() << "a missing file was accepted";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("cannot open"), std::string::npos) << e.what();
  }
}

TEST(Checkpoint, WriteFailureNamesThePath) {
  const Scene s = test::scene("falling-cubes", 20);
  Simulation a(s);
  const std::string path = "/nonexistent-dir/x.ckpt";
  try {
    a.save(path);
    ADD_FAILURE() << "saved to " << path;
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

// Inputs given out of step order, one of them at a step the worlds have
// passed (a rollback): the log lists them in the order they apply, and a
// fresh run given the log file's inputs ends on the same hash.
TEST(InputLog, ReplaysToTheSameHash) {
  const Scene s = test::scene("cube-pile", 150);
  SimulationConfig config{.territories = 2, .past_inputs = true};
  Simulation a(s, config);
  const Ids ids = give_inputs(a, s);
  {
    SceneReader screen = a.add_reader();  // holds the commit horizon at the frame it shows
    ASSERT_TRUE(a.advance_to(a.time_of(55)));
    ASSERT_TRUE(screen.read_at(a.time_of(55)).has_value());
    ASSERT_TRUE(a.advance_to(a.time_of(70)));
    a.apply_impulse(a.time_of(55), ids.added, Vec3(0, 3, 1));  // at the frame on screen, passed: a rollback
  }
  a.set_velocity(a.time_of(90), ids.pushed, Vec3(-1, 2, 0));
  ASSERT_TRUE(a.advance_to(a.time_of(kSteps)));
  EXPECT_EQ(a.rollbacks(), 1u);
  const std::vector<UserInput> log = a.input_log();
  ASSERT_EQ(log.size(), 7u);
  for (std::size_t i = 1; i < log.size(); ++i) EXPECT_LE(log[i - 1].step, log[i].step);
  const std::string path = scratch("inputs.json");
  a.write_input_log(path);
  const std::vector<UserInput> read = load_input_file(path);
  ASSERT_EQ(read.size(), log.size());

  Simulation b(s, SimulationConfig{.territories = 4});
  for (const UserInput& in : read) b.give(in);
  ASSERT_TRUE(b.advance_to(b.time_of(kSteps)));
  std::printf("[ cube-pile 150, %zu inputs logged (one at a past step), K 2 past_inputs ] %s, replayed from %s on "
              "K 4: %s\n",
              log.size(), hash_hex(a.state_hash()).c_str(), path.c_str(), hash_hex(b.state_hash()).c_str());
  EXPECT_EQ(hash_hex(b.state_hash()), hash_hex(a.state_hash()));
  // A restored Simulation logs only what was given to it, not the queued
  // inputs of its snapshot.
  Simulation c = Simulation::resume(saved().path, {});
  EXPECT_TRUE(c.input_log().empty());
  give_late_input(c, saved().ids);
  EXPECT_EQ(c.input_log().size(), 1u);
  std::filesystem::remove(path);
}

// A version-1 checkpoint (written by the float build before bodies carried
// a collision filter: cube-pile 40 saved at step 30 by `soda run --scene
// cube-pile --n 40 --steps 60 --checkpoint-at 30 --checkpoint ...`) still
// resumes: its bodies read back with the default filter, and the run
// reaches at step 60 the hash of one CanonicalWorld built from the file's
// state (the run that wrote it reached f0eac91474662d74 under the solver
// defaults of then; docs/stress.md's defaults have changed since).
TEST(Checkpoint, VersionOneFilesResumeWithTheDefaultFilter) {
  const std::string path = std::string(SODA_RUNTIME_TEST_DATA) + "/cube-pile-40-step30.v1.ckpt";
  const std::vector<std::uint8_t> bytes = file_bytes(path);
  ASSERT_FALSE(bytes.empty()) << path;
  if (sizeof(btScalar) != 4) {
    EXPECT_THROW((void)decode_checkpoint(bytes, path), CheckpointError);  // the float build's file
    return;
  }
  EXPECT_EQ(checkpoint_header(bytes, path).version, 1u);
  const SimulationSnapshot snap = decode_checkpoint(bytes, path);
  ASSERT_EQ(snap.state.bodies.size(), 41u);
  for (const BodySnapshot& b : snap.state.bodies) {
    EXPECT_EQ(b.description.collision_group, kDefaultCollisionGroup);
    EXPECT_EQ(b.description.collision_mask, kAllCollisionGroups);
  }
  CanonicalWorld one(snap.state);
  for (int i = 30; i < 60; ++i) one.step();
  for (int territories : {1, 2}) {
    Simulation sim = Simulation::resume(path, SimulationConfig{.territories = territories});
    ASSERT_TRUE(sim.advance_to(sim.time_of(60)));
    std::printf("[ version-1 checkpoint, K %d ] step 60: %s (one CanonicalWorld: %s)\n", territories,
                hash_hex(sim.state_hash()).c_str(), hash_hex(one.state_hash()).c_str());
    EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(one.state_hash()));
  }
  // Written again, it is version 2 and reads back the same.
  const std::vector<std::uint8_t> again = encode_checkpoint(snap);
  EXPECT_EQ(checkpoint_header(again, "again").version, kCheckpointVersion);
  EXPECT_EQ(encode_checkpoint(decode_checkpoint(again, "again")), again);
}

}  // namespace
}  // namespace soda
