// `soda stress`: the numerical-stability suite (docs/stress.md).
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <stdexcept>
#include <string>

#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>

#include "commands.h"
#include "soda/bench/accuracy_process.h"
#include "soda/bench/stress.h"
#include "soda/worlds/body_state.h"

namespace soda::cli {
namespace {

struct StressOptions {
  std::vector<std::string> cases;  // empty: all
  bool quick = false;
  bool no_sibling = false;
  std::string sibling;
  std::string csv = "stress.csv";
  std::string markdown;
  std::string json;
  std::string dt;      // "" : each scene's own
  int iterations = 0;  // 0 : each scene's own
  int substeps = 0;    // 0 : each scene's own
  std::string variant;  // diagnosis: solver_variant.h
  bool stock = false;   // run every case in Bullet's stock world
  int solver_threads = 1;  // canonical world: threads of the coloured solve
};

void write_text(const std::string& path, const std::string& text) {
  std::ofstream out(path, std::ios::trunc);
  if (!out) throw std::runtime_error(path + ": cannot open for writing");
  out << text;
  if (!out) throw std::runtime_error(path + ": write failed");
}

int run_stress(StressOptions& o) {
  std::vector<StressCase> suite = stress_suite(o.quick);
  if (!o.cases.empty()) {
    const std::set<std::string> wanted(o.cases.begin(), o.cases.end());
    std::vector<StressCase> chosen;
    for (const StressCase& c : suite)
      if (wanted.count(c.name) || wanted.count(c.group)) chosen.push_back(c);
    if (chosen.empty()) throw std::invalid_argument("--cases: no case or group of that name (see docs/stress.md)");
    suite = chosen;
  }
  double dt = 0.0;
  if (!o.dt.empty()) try {
      dt = parse_step_size(o.dt);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("--dt: ") + e.what());
    }
  for (StressCase& c : suite) {
    c = with_settings(c, dt, o.iterations);
    if (o.substeps > 0) c.substeps = o.substeps;
    c.variant = o.variant;
    c.solver_threads = o.solver_threads;
    if (o.stock) c.world = WorldKind::Stock;
  }
  std::vector<StressResult> results;
  std::vector<std::string> other;  // cases to run in the other precision too
  for (const StressCase& c : suite) {
    spdlog::info("stress {} ({} steps, {} world{})...", c.name, c.steps, world_kind_name(c.world),
                 c.ccd ? " + CCD" : "");
    StressResult r = run_stress_case(c);
    spdlog::info("stress {}: {} — {}", c.name, r.status, r.measured);
    results.push_back(r);
    if (c.both_precisions) other.push_back(c.name);
  }
  if (!other.empty() && !o.no_sibling) {
    const std::string sibling = o.sibling.empty() ? default_sibling_binary() : o.sibling;
    if (!is_executable(sibling)) {
      for (const std::string& name : other)
        for (const StressCase& c : suite)
          if (c.name == name) {
            StressResult r;
            r.c = c;
            r.precision = other_precision_name();
            r.status = "not available";
            r.measured = "no " + std::string(other_precision_name()) + " binary at '" + sibling + "'";
            results.push_back(r);
          }
    } else {
      char tmpl[] = "/tmp/soda-stress-XXXXXX";
      if (!::mkdtemp(tmpl)) throw std::runtime_error("cannot create a temporary folder under /tmp");
      const std::string json = std::string(tmpl) + "/other.json";
      std::string list;
      for (const std::string& n : other) list.append(list.empty() ? "" : ",").append(n);
      std::vector<std::string> argv = {sibling, "stress", "--cases", list, "--no-sibling", "--csv",
                                       std::string(tmpl) + "/other.csv", "--json", json, "--log-level", "warn"};
      if (o.quick) argv.push_back("--quick");
      if (!o.dt.empty()) argv.insert(argv.end(), {"--dt", o.dt});
      if (o.iterations > 0) argv.insert(argv.end(), {"--iterations", std::to_string(o.iterations)});
      spdlog::info("running {} in the {} build: {}", list, other_precision_name(), sibling);
      try {
        run_process(argv);
        std::ifstream in(json);
        const nlohmann::json j = nlohmann::json::parse(in);
        for (const auto& row : j) results.push_back(stress_from_json(row));
      } catch (...) {
        std::filesystem::remove_all(tmpl);
        throw;
      }
      std::filesystem::remove_all(tmpl);
    }
  }
  // Report order: the suite's, float before double.
  std::stable_sort(results.begin(), results.end(), [&](const StressResult& a, const StressResult& b) {
    auto index = [&](const std::string& n) {
      for (std::size_t i = 0; i < suite.size(); ++i)
        if (suite[i].name == n) return i;
      return suite.size();
    };
    return index(a.c.name) < index(b.c.name);
  });
  std::string csv = stress_csv_header() + "\n";
  nlohmann::json j = nlohmann::json::array();
  for (const StressResult& r : results) {
    csv += stress_csv_row(r) + "\n";
    j.push_back(stress_json(r));
    std::printf("%-6s %-26s %-9s %-6s %s\n", r.status.c_str(), r.c.name.c_str(),
                (std::string(world_kind_name(r.c.world)) + (r.c.ccd ? "+ccd" : "")).c_str(), r.precision.c_str(),
                r.measured.c_str());
  }
  if (!o.csv.empty()) write_text(o.csv, csv);
  if (!o.markdown.empty()) write_text(o.markdown, stress_markdown(results));
  if (!o.json.empty()) write_text(o.json, j.dump(2) + "\n");
  const StressTally tally = stress_tally(results);
  std::printf("%s (failures are findings: docs/stress.md)\n", stress_tally_text(tally).c_str());
  const int status = stress_exit_status(tally);
  if (status != 0)
    std::fprintf(stderr, "soda: stress: %d SODA case%s FAILed, %d row%s could not run (exit %d)\n", tally.fail,
                 tally.fail == 1 ? "" : "s", tally.other + tally.stock_other,
                 tally.other + tally.stock_other == 1 ? "" : "s", status);
  return status;
}

}  // namespace

Command add_stress_command(CLI::App& app) {
  auto o = std::make_shared<StressOptions>();
  CLI::App* cmd = app.add_subcommand("stress", "Numerical-stability suite: towers, pyramids, mass ratios, "
                                               "bullet vs wall, far origin, joints (chains, a ragdoll pile, motors), "
                                               "dense pile, long run");
  cmd->add_option("--cases", o->cases, "Cases or groups to run (default: all), e.g. tower-20,far-origin")
      ->delimiter(',');
  cmd->add_flag("--quick", o->quick, "Short versions of the cases whose criterion holds over a shorter run (far-origin keeps its 20 s: "
              "settling is its criterion)");
  cmd->add_option("--dt", o->dt, "Override every scene's step (1/120 or seconds); steps scale to the same time");
  cmd->add_option("--iterations", o->iterations, "Override every scene's solver iterations");
  cmd->add_option("--substeps", o->substeps, "Override every case's substeps per step (stock Bullet's joint chains run 4)");
  cmd->add_option("--variant", o->variant,
                  "Diagnosis: solver settings to change, e.g. ws=1,erp2=0.8,nosleep (bench/include/soda/bench/"
                  "solver_variant.h)");
  cmd->add_flag("--stock", o->stock, "Run every case in Bullet's stock world (the comparison column)");
  cmd->add_option("--solver-threads", o->solver_threads,
                  "Canonical world: threads of the coloured solve of large islands (results are identical for "
                  "every value; docs/coloured-solve.md)")
      ->check(CLI::Range(1, 256));
  cmd->add_option("--sibling", o->sibling, "The other precision's binary (default: next to this one)");
  cmd->add_flag("--no-sibling", o->no_sibling, "Do not run the two-precision cases in the other build");
  cmd->add_option("--csv", o->csv, "Output CSV ('' for none)")->capture_default_str();
  cmd->add_option("--markdown", o->markdown, "Also write a markdown result table");
  cmd->add_option("--json", o->json, "Also write the results as JSON");
  return {cmd, [o] { return run_stress(*o); }};
}

}  // namespace soda::cli
