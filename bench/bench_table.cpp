// The human-readable table of `soda bench` (bench.h, bench_table).
#include <string>

#include <spdlog/fmt/fmt.h>

#include "soda/bench/bench.h"
#include "soda/worlds/body_state.h"

namespace soda {
namespace {

// "wall s, speed-up vs stock, asleep" of one run in one sleeping setting.
std::string cells(const RunResult& r, const RunResult& stock) {
  const double speedup = r.wall_seconds > 0 ? stock.wall_seconds / r.wall_seconds : 0.0;
  return fmt::format("{:>8.3f} {:>7.2f}x {:>6}/{:<6}", r.wall_seconds, speedup, r.sleeping_bodies, r.dynamic_bodies);
}

std::string row(const std::string& label, const RunResult BenchSet::*which, const BenchResult& b) {
  std::string line = fmt::format("{:<30}{}", label, cells(b.*which, b.baseline));
  if (b.has_awake) line += "   " + cells(b.awake.*which, b.awake.baseline);
  return line + "\n";
}

std::string verdict(const BenchSet& s) {
  return s.run.state_hash == s.one_territory.state_hash ? "identical (" + hash_hex(s.run.state_hash) + ")"
                                                        : "DIFFERENT (" + hash_hex(s.run.state_hash) + " vs " +
                                                              hash_hex(s.one_territory.state_hash) + ")";
}

}  // namespace

std::string bench_table(const BenchResult& b) {
  const int k = b.run.territories;
  const std::string tested =
      k > 1 ? fmt::format("SODA, {} territories", k) : fmt::format("{} world, 1 territory", world_kind_name(b.run.world));
  std::string t;
  t += fmt::format("{:<30}{:<30}{}\n", "", "sleeping on (Bullet default)", b.has_awake ? "   sleeping off" : "");
  const std::string head = fmt::format("{:>8} {:>8} {:>13}", "wall s", "speed-up", "asleep at end");
  t += fmt::format("{:<30}{}{}\n", "", head, b.has_awake ? "   " + head : std::string());
  t += row("stock Bullet, 1 world", &BenchSet::baseline, b);
  if (k > 1) t += row("SODA, 1 territory", &BenchSet::one_territory, b);
  t += row(tested, &BenchSet::run, b);
  if (k > 1) {
    t += fmt::format("{} territories vs 1: {:.2f}x sleeping on", k, b.speedup_vs_one_territory);
    if (b.has_awake) t += fmt::format(", {:.2f}x sleeping off", b.awake.speedup_vs_one_territory);
    t += "\n";
    t += fmt::format("state hash, {} territories vs 1: {}", k, verdict(b));
    if (b.has_awake) t += fmt::format("; sleeping off {}", verdict(b.awake));
    t += "\n";
  }
  t += "speed-up = stock Bullet's wall time / this row's, same process, same scene (> 1: faster than stock).\n";
  t += "Sleeping on: SODA's islands come from contacts, stock Bullet's from broadphase pairs, so SODA's bodies fall\n"
       "asleep sooner and it solves fewer of them: part of that speed-up is sleep, not a faster step.\n";
  if (b.has_awake)
    t += "Sleeping off: no body ever sleeps in any run; every body is solved every step on both sides.\n";
  return t;
}

}  // namespace soda
