// Contact events (contact_reader.h, docs/contact-events.md): the stream of
// begin/end events of a scene — steps, pair ids, points and impulses bit for
// bit — is the one CanonicalWorld's manifolds give, for any number of
// territories, partition, schedule and speculation with rollbacks; no event
// comes from a step later rolled back; events off leave the run unchanged.
// Label "concurrency" (ThreadSanitizer in CI): readers and the callback run
// while the worlds do.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <condition_variable>
#include <functional>
#include <mutex>
#include <cstring>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "runtime/simulation_test_util.h"
#include "soda/grid/partition.h"
#include "soda/runtime/world_metrics.h"

namespace soda {
namespace {

// The events CanonicalWorld's contact state gives (every manifold with
// points after each step: its snapshot), written independently of the
// runtime's recording and diffing: steps 0 .. steps.
std::vector<ContactStep> canonical_stream(const Scene& s, int steps, bool persist,
                                          std::uint64_t* final_hash = nullptr) {
  CanonicalWorld w(s);
  std::vector<ContactStep> out;
  std::vector<ManifoldState> before;
  for (int t = 0; t <= steps; ++t) {
    if (t > 0) w.step();
    std::vector<ManifoldState> now;
    for (const ManifoldState& m : w.snapshot().manifolds)
      if (!m.points.empty()) now.push_back(m);
    ContactStep cs;
    cs.step = t;
    cs.time = t * s.settings.dt;
    auto key = [](const ManifoldState& m) { return std::make_pair(m.id0, m.id1); };
    auto event = [&](ContactEventKind kind, const ManifoldState& m) {
      ContactEvent e;
      e.step = t;
      e.kind = kind;
      e.a = m.id0;
      e.b = m.id1;
      if (kind != ContactEventKind::End) {
        e.point_count = static_cast<std::uint32_t>(m.points.size());
        for (std::size_t i = 0; i < m.points.size(); ++i) {
          const ContactPointState& p = m.points[i];
          std::memcpy(e.points[i].position_on_a, p.position_world_on_a, sizeof p.position_world_on_a);
          std::memcpy(e.points[i].position_on_b, p.position_world_on_b, sizeof p.position_world_on_b);
          std::memcpy(e.points[i].normal_on_b, p.normal_world_on_b, sizeof p.normal_world_on_b);
          e.points[i].distance = p.distance;
          e.points[i].impulse = p.applied_impulse;
        }
      }
      cs.events.push_back(e);
    };
    std::size_t i = 0, j = 0;
    while (i < before.size() || j < now.size()) {
      if (j == now.size() || (i < before.size() && key(before[i]) < key(now[j]))) event(ContactEventKind::End, before[i++]);
      else if (i == before.size() || key(now[j]) < key(before[i])) event(ContactEventKind::Begin, now[j++]);
      else {
        if (persist) event(ContactEventKind::Persist, now[j]);
        ++i, ++j;
      }
    }
    out.push_back(std::move(cs));
    before = std::move(now);
  }
  if (final_hash) *final_hash = w.state_hash();
  return out;
}

// Every step 0 .. steps through one reader, on this thread.
std::vector<ContactStep> read_all(ContactReader& reader, int steps) {
  std::vector<ContactStep> out;
  for (int t = 0; t <= steps; ++t) {
    std::optional<ContactStep> s = reader.read_step(t);
    if (!s) break;
    out.push_back(std::move(*s));
  }
  return out;
}

bool same_event(const ContactEvent& x, const ContactEvent& y) {
  if (x.step != y.step || x.kind != y.kind || x.a != y.a || x.b != y.b || x.point_count != y.point_count) return false;
  for (std::uint32_t i = 0; i < x.point_count; ++i)
    if (std::memcmp(&x.points[i], &y.points[i], sizeof x.points[i]) != 0) return false;
  return true;
}

// "" if equal bit for bit; else the first difference, by step.
std::string stream_difference(const std::vector<ContactStep>& got, const std::vector<ContactStep>& want) {
  if (got.size() != want.size())
    return std::to_string(got.size()) + " steps, expected " + std::to_string(want.size());
  for (std::size_t t = 0; t < want.size(); ++t) {
    const auto& g = got[t].events;
    const auto& w = want[t].events;
    if (got[t].step != want[t].step) return "step " + std::to_string(got[t].step) + " in place of " + std::to_string(want[t].step);
    if (g.size() != w.size())
      return "step " + std::to_string(want[t].step) + ": " + std::to_string(g.size()) + " events, expected " +
             std::to_string(w.size());
    for (std::size_t i = 0; i < w.size(); ++i)
      if (!same_event(g[i], w[i]))
        return "step " + std::to_string(want[t].step) + ": event " + std::to_string(i) + " (pair " +
               std::to_string(w[i].a) + "-" + std::to_string(w[i].b) + " " + to_string(w[i].kind) + ") differs";
  }
  return "";
}

struct Counts {
  std::size_t begins = 0, ends = 0, persists = 0;
};

Counts count(const std::vector<ContactStep>& stream) {
  Counts c;
  for (const ContactStep& s : stream)
    for (const ContactEvent& e : s.events)
      (e.kind == ContactEventKind::Begin ? c.begins : e.kind == ContactEventKind::End ? c.ends : c.persists)++;
  return c;
}

// The reference itself is worth testing: plenty of begins and ends, and
// impulses, so that the comparisons below compare something.
void expect_rich(const std::vector<ContactStep>& stream, const char* what) {
  const Counts c = count(stream);
  EXPECT_GT(c.begins, 40u) << what;
  EXPECT_GT(c.ends, 10u) << what;
  bool impulse = false;
  for (const ContactStep& s : stream)
    for (const ContactEvent& e : s.events) impulse = impulse || e.total_impulse() > 0;
  EXPECT_TRUE(impulse) << what;
}

// One territory (no speculation) reports exactly what the one CanonicalWorld
// holds, and the stream is well formed: ascending pairs, begins with points,
// ends without, each pair alternating begin/end.
TEST(ContactEvents, OneTerritoryStreamIsTheCanonicalWorldsContacts) {
  constexpr int kSteps = 80;
  const Scene s = test::scene("cube-pile", 64);
  std::uint64_t hash = 0;
  const std::vector<ContactStep> want = canonical_stream(s, kSteps, false, &hash);
  expect_rich(want, "canonical cube-pile 64");
  Simulation sim(s, {.territories = 1, .contact_events = true});
  ContactReader reader = sim.add_contact_reader();
  sim.start(sim.time_of(kSteps));
  const std::vector<ContactStep> got = read_all(reader, kSteps);
  EXPECT_EQ(stream_difference(got, want), "");
  std::map<std::pair<BodyId, BodyId>, bool> touching;
  for (const ContactStep& st : got) {
    for (std::size_t i = 0; i < st.events.size(); ++i) {
      const ContactEvent& e = st.events[i];
      EXPECT_LT(e.a, e.b);
      if (i > 0) EXPECT_LT(std::make_pair(st.events[i - 1].a, st.events[i - 1].b), std::make_pair(e.a, e.b));
      bool& on = touching[{e.a, e.b}];
      if (e.kind == ContactEventKind::Begin) {
        EXPECT_FALSE(on) << "pair " << e.a << "-" << e.b << " begins twice, step " << st.step;
        EXPECT_GE(e.point_count, 1u);
        EXPECT_LE(e.point_count, 4u);
        on = true;
      } else {
        EXPECT_EQ(e.kind, ContactEventKind::End);
        EXPECT_TRUE(on) << "pair " << e.a << "-" << e.b << " ends untouched, step " << st.step;
        EXPECT_EQ(e.point_count, 0u);
        on = false;
      }
    }
  }
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(hash));
}

// K = 2, 4, 8, kmeans and strips, every schedule, speculation with lost
// bets and rollbacks: the same stream as the one CanonicalWorld, bit for
// bit, step by step — a step rolled back after its entry was published
// would show here as an event the canonical run does not have (the
// speculative strip rolls back in every run, on one thread: asserted).
using Case = test::SpeculationCase;

class ContactEventsAnyK : public ::testing::TestWithParam<Case> {};

TEST_P(ContactEventsAnyK, StreamEqualsOneWorldAndNoEventFromARolledBackStep) {
  const Case c = GetParam();
  constexpr int kSteps = 80;
  const Scene s = test::scene(c.scene, c.bodies);
  std::uint64_t hash = 0;
  const std::vector<ContactStep> want = canonical_stream(s, kSteps, true, &hash);
  expect_rich(want, c.scene);
  const TerritoryMap map = make_partition(c.partition, s, c.territories, GridOptions{});
  SimulationConfig config = test::speculation_config(c);
  config.contact_events = true;
  Simulation sim(s, map, config);
  std::vector<ContactStep> got;
  std::thread reader([&, r = sim.add_contact_reader(true)]() mutable { got = read_all(r, kSteps); });
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  reader.join();
  EXPECT_EQ(stream_difference(got, want), "");
  EXPECT_EQ(contact_stream_hash(got), contact_stream_hash(want));
  EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(hash));
  const WorldMetrics t = test::total(sim.metrics());
  std::printf("[ %s %d %s K=%d threads %d anticipation %d ] %zu begins, %zu ends, %zu persists; %llu rollbacks, "
              "%llu steps rejoined\n",
              c.scene, c.bodies, c.partition, c.territories, c.threads, c.anticipation, count(got).begins,
              count(got).ends, count(got).persists, (unsigned long long)t.rollbacks,
              (unsigned long long)t.steps_rejoined);
  // On one thread the worlds of a strip run round-robin: the far end runs
  // ahead, loses bets and rolls back in every run (simulation_speculation_test.cpp).
  if (c.anticipation > 0 && c.threads == 1) EXPECT_GT(t.rollbacks, 0u);
}

INSTANTIATE_TEST_SUITE_P(
    ContactEvents, ContactEventsAnyK,
    ::testing::Values(Case{"falling-cubes", 100, 8, "grid:8x1x1", 1, 8},  // rolls back in every run
                      Case{"cube-pile", 64, 4, "grid:4x1x1", 1, 8},       // a giant merged island, rolled back
                      Case{"cube-pile", 64, 4, "kmeans", 0, 8},           // a thread per world, speculative
                      Case{"cube-pile", 64, 2, "kmeans", 2, 0},           // a pool of 2, lockstep
                      Case{"cube-pile", 64, 4, "rcb", 3, 0}),             // a pool of 3, lockstep
    test::speculation_case_name);

// Every world's newest finished scene step (re-runs included), with a
// condition variable: the test waits on it, never on a clock.
struct WorldsProgress {
  std::mutex mutex;
  std::condition_variable cv;
  std::vector<std::int64_t> newest;
  explicit WorldsProgress(int worlds) : newest(static_cast<std::size_t>(worlds), 0) {}
  std::function<void(WorldId, std::int64_t)> hook() {
    return [this](WorldId w, std::int64_t step) {
      std::lock_guard lock(mutex);
      newest[static_cast<std::size_t>(w)] = std::max(newest[static_cast<std::size_t>(w)], step);
      cv.notify_all();
    };
  }
  void wait_all_past(std::int64_t step) {
    std::unique_lock lock(mutex);
    cv.wait(lock, [&] { return *std::min_element(newest.begin(), newest.end()) > step; });
  }
};

// Steps every world has published but that are not final yet (a reader
// holds the horizon at step 10) are never served; an input at step 15 then
// rolls every world back and rewrites them with a body that hits the ground:
// the events read afterwards are the rewritten steps', equal to the run that
// had the body from the start. A reader serving a published step before it
// is final fails here twice: try_read_step(16) answers, and the stream lacks
// the new body.
TEST(ContactEvents, NoEventFromAStepThatIsRolledBack) {
  constexpr int kSteps = 60;
  constexpr std::int64_t kInput = 15;
  const Scene s = test::scene("falling-cubes", 100);
  const BodyId added = test::unused_id(s);
  const Body cube = test::new_cube(added, Vec3(0.3, 1.0, 0.2));  // on the ground within ~12 steps

  Simulation one(s, {.threads = 1, .contact_events = true});
  one.add_body(one.time_of(kInput), cube);
  ContactReader one_reader = one.add_contact_reader();
  one.start(one.time_of(kSteps));
  const std::vector<ContactStep> want = read_all(one_reader, kSteps);
  bool begins = false;
  for (const ContactStep& st : want)
    for (const ContactEvent& e : st.events)
      begins = begins || (e.kind == ContactEventKind::Begin && e.step > kInput && (e.a == added || e.b == added));
  ASSERT_TRUE(begins) << "the added cube touches nothing: the test would not test";

  WorldsProgress progress(2);
  SimulationConfig config{.territories = 2, .threads = 1, .buffer_capacity = 96, .past_inputs = true,
                          .contact_events = true};
  config.runtime.anticipation = 8;
  config.after_step = progress.hook();
  Simulation sim(s, config);
  SceneReader frames = sim.add_reader();
  ContactReader contacts = sim.add_contact_reader();
  sim.start(sim.time_of(kSteps));
  ASSERT_TRUE(frames.read_at(sim.time_of(10)));  // holds the horizon at step 10
  progress.wait_all_past(kInput + 1);  // every world has published 16
  EXPECT_LE(sim.commit_horizon_step(), 10);
  ASSERT_TRUE(contacts.read_step(10));
  EXPECT_FALSE(contacts.try_read_step(kInput + 1)) << "a step above the commit horizon was served";
  sim.add_body(sim.time_of(kInput), cube);  // a rollback of every world to step 15
  EXPECT_EQ(sim.rollbacks(), 1u);
  // Lets the horizon go on (the buffers hold every step: this thread reads
  // the contacts only after it).
  ASSERT_TRUE(frames.read_at(sim.time_of(kSteps)));
  std::vector<ContactStep> got(want.begin(), want.begin() + 10);  // steps 0 .. 9, as read before (not again)
  std::optional<ContactStep> at10 = contacts.read_step(10);  // the last step read: read again
  ASSERT_TRUE(at10);
  got.push_back(std::move(*at10));
  for (int t = 11; t <= kSteps; ++t) {
    std::optional<ContactStep> st = contacts.read_step(t);
    ASSERT_TRUE(st) << "step " << t;
    got.push_back(std::move(*st));
  }
  EXPECT_EQ(stream_difference(got, want), "");
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
}

// Events off: nothing to read, and the run is the run with them on (the
// canonical hash at every step read), so recording changes nothing.
TEST(ContactEvents, OffByDefaultAndOnOrOffTheSameRun) {
  constexpr int kSteps = 40;
  const Scene s = test::scene("cube-pile", 64);
  const test::Reference ref = test::reference_run(s, kSteps);
  for (bool on : {false, true}) {
    SimulationConfig config{.territories = 4, .contact_events = on};
    Simulation sim(s, config);
    if (!on) {
      EXPECT_THROW(sim.add_contact_reader(), std::logic_error);
    }
    SceneReader frames = sim.add_reader();
    sim.start(sim.time_of(kSteps));
    for (int k = 0; k <= kSteps; ++k) {
      std::optional<SceneFrame> f = frames.read_at(sim.time_of(k));
      ASSERT_TRUE(f);
      EXPECT_EQ(test::frame_difference(f->poses, ref.frames[static_cast<std::size_t>(k)]), "") << "step " << k;
    }
    EXPECT_EQ(hash_hex(sim.state_hash()), hash_hex(ref.hashes[kSteps])) << (on ? "on" : "off");
  }
  SimulationConfig bad;
  bad.on_contacts = [](const ContactStep&) {};
  EXPECT_THROW(Simulation(s, bad), std::invalid_argument);
}

// The callback: every step from the first, in order, once, on one thread
// that is not the caller's; the same events as a reader's. With persist,
// begins and ends are those of a reader without.
TEST(ContactEvents, CallbackGetsEveryStepInOrderOnOneThread) {
  constexpr int kSteps = 60;
  const Scene s = test::scene("cube-pile", 64);
  std::vector<ContactStep> called;
  std::atomic<int> threads_seen{0};
  std::thread::id callback_thread;
  SimulationConfig config{.territories = 4, .contact_events = true};
  config.runtime.anticipation = 4;
  config.on_contacts = [&](const ContactStep& step) {
    if (called.empty()) callback_thread = std::this_thread::get_id();
    if (std::this_thread::get_id() != callback_thread) ++threads_seen;
    called.push_back(step);
  };
  config.on_contacts_persist = true;
  Simulation sim(s, config);
  ContactReader reader = sim.add_contact_reader();
  EXPECT_TRUE(sim.advance_to(sim.time_of(kSteps)));
  const std::vector<ContactStep> read = read_all(reader, kSteps);
  sim.stop();  // delivers every final step, then joins the callback's thread
  ASSERT_GE(called.size(), static_cast<std::size_t>(kSteps + 1));
  EXPECT_EQ(threads_seen.load(), 0);
  EXPECT_NE(callback_thread, std::this_thread::get_id());
  for (std::size_t t = 0; t < called.size(); ++t) EXPECT_EQ(called[t].step, static_cast<std::int64_t>(t));
  called.resize(kSteps + 1);
  std::vector<ContactStep> without_persist = called;
  for (ContactStep& st : without_persist)
    std::erase_if(st.events, [](const ContactEvent& e) { return e.kind == ContactEventKind::Persist; });
  EXPECT_GT(count(called).persists, 0u);
  EXPECT_EQ(stream_difference(without_persist, read), "");
  EXPECT_EQ(stream_difference(called, canonical_stream(s, kSteps, true)), "");
}

// A callback that throws fails the run with its message.
TEST(ContactEvents, CallbackExceptionFailsTheRun) {
  const Scene s = test::scene("cube-pile", 64);
  SimulationConfig config{.territories = 2, .contact_events = true};
  config.on_contacts = [](const ContactStep& step) {
    if (step.step == 5) throw std::runtime_error("sound card on fire");
  };
  Simulation sim(s, config);
  sim.start(sim.time_of(200));
  try {
    sim.advance_to(sim.time_of(200));
    sim.stop();
    ADD_FAILURE() << "no error";
  } catch (const SimulationError& e) {
    EXPECT_EQ(e.world(), kNoWorld);
    EXPECT_NE(e.message().find("sound card on fire"), std::string::npos) << e.message();
  }
}

// Reads go forward; the last step may be read again; try_ never waits;
// before the first step is refused.
TEST(ContactEvents, ReadsGoForward) {
  const Scene s = test::scene("cube-pile", 64);
  Simulation sim(s, {.territories = 2, .contact_events = true});
  ContactReader reader = sim.add_contact_reader();
  EXPECT_FALSE(reader.try_read_step(10));  // not run yet
  EXPECT_THROW(reader.read_step(-1), std::invalid_argument);
  EXPECT_TRUE(sim.advance_to(sim.time_of(20)));
  std::optional<ContactStep> s10 = reader.read_step(10);
  ASSERT_TRUE(s10);
  EXPECT_EQ(reader.last_step(), 10);
  std::optional<ContactStep> again = reader.read_step(10);
  ASSERT_TRUE(again);
  EXPECT_EQ(contact_stream_hash({*again}), contact_stream_hash({*s10}));
  EXPECT_FALSE(reader.read_step(9));
  std::optional<ContactStep> s11 = reader.read_next();
  ASSERT_TRUE(s11);
  EXPECT_EQ(s11->step, 11);
  const std::vector<ContactStep> want = canonical_stream(s, 20, false);
  EXPECT_EQ(stream_difference({*s10, *s11}, {want[10], want[11]}), "");
}

}  // namespace
}  // namespace soda
