// Contact sounds (docs/contact-events.md): cubes dropped on a floor, on 2
// territories that speculate (worlds run up to 8 steps ahead and roll back
// lost bets). A callback gets the contact events of every committed step,
// in step order, on one thread of its own, and plays a "clack" for each
// begin event whose impulse is above a threshold (loud enough to hear).
// Only committed steps are delivered: no sound for a contact a rollback
// takes back. The same scene on one world, read through a ContactReader,
// gives the same events bit for bit; the run ends on the one-world state
// hash and event stream hash.
// Usage: contact_sounds [N] [SECONDS] [THRESHOLD]   (N cubes, default 200;
// default 4 s; impulse threshold in N s, default 2)
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <vector>

#include "soda/runtime/simulation.h"

int main(int argc, char** argv) {
  try {
    const int n = argc > 1 ? std::atoi(argv[1]) : 200;
    const double seconds = argc > 2 ? std::atof(argv[2]) : 4.0;
    const double threshold = argc > 3 ? std::atof(argv[3]) : 2.0;
    const soda::Scene scene = soda::make_scene("falling-cubes", {n, 1});

    std::vector<soda::ContactStep> heard;  // the callback's thread only, until stop()
    std::size_t clacks = 0;
    soda::SimulationConfig config{.territories = 2, .contact_events = true};
    config.runtime.anticipation = 8;
    config.on_contacts = [&](const soda::ContactStep& step) {
      for (const soda::ContactEvent& e : step.events) {
        if (e.kind != soda::ContactEventKind::Begin || e.total_impulse() <= threshold) continue;
        if (++clacks <= 25)
          std::printf("t = %.3f s (step %lld): clack, bodies %u and %u, impulse %.2f N s at (%.2f, %.2f, %.2f)\n",
                      step.time, static_cast<long long>(step.step), e.a, e.b, static_cast<double>(e.total_impulse()),
                      static_cast<double>(e.points[0].position_on_b[0]),
                      static_cast<double>(e.points[0].position_on_b[1]),
                      static_cast<double>(e.points[0].position_on_b[2]));
      }
      heard.push_back(step);
    };
    soda::Simulation sim(scene, config);
    sim.advance_to(seconds);
    const std::uint64_t hash = sim.state_hash();
    const std::int64_t last = sim.steps_done();
    sim.stop();  // every committed step has reached the callback once this returns
    if (clacks > 25) std::printf("... and %zu more clacks\n", clacks - 25);
    heard.resize(static_cast<std::size_t>(last + 1));  // steps 0 .. last (stop() may have committed more)

    // One world, its events read through a reader.
    soda::Simulation one(scene, {.threads = 1, .contact_events = true});
    soda::ContactReader reader = one.add_contact_reader();
    one.start(seconds);
    std::vector<soda::ContactStep> expected;
    for (std::int64_t s = 0; s <= last; ++s)
      if (auto step = reader.read_step(s)) expected.push_back(*step);
    one.advance_to(seconds);
    const std::uint64_t events = soda::contact_stream_hash(heard);
    const std::uint64_t one_events = soda::contact_stream_hash(expected);
    const bool ok = hash == one.state_hash() && events == one_events && heard.size() == expected.size();
    std::printf("%zu steps, %zu clacks above %.2f N s; state hash %016llx, one world %016llx; event stream %016llx, "
                "one world %016llx: %s\n",
                heard.size(), clacks, threshold, static_cast<unsigned long long>(hash),
                static_cast<unsigned long long>(one.state_hash()), static_cast<unsigned long long>(events),
                static_cast<unsigned long long>(one_events), ok ? "equal" : "DIFFERENT");
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "contact_sounds: %s\n", e.what());
    return 1;
  }
}
