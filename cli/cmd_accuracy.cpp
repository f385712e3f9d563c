// `soda bench accuracy`, `soda bench accuracy-trace`, `soda bench analytic`
// (docs/accuracy.md).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <stdexcept>
#include <string>

#include <spdlog/spdlog.h>

#include "commands.h"
#include "soda/bench/accuracy.h"
#include "soda/bench/accuracy_analytic.h"
#include "soda/bench/accuracy_process.h"
#include "soda/bench/accuracy_sweep.h"
#include "soda/bench/csv.h"
#include "soda/worlds/body_state.h"

namespace soda::cli {
namespace {

WorldKind parse_world(const std::string& w) {
  if (w == "canonical") return WorldKind::Canonical;
  if (w == "stock") return WorldKind::Stock;
  throw std::invalid_argument("--world must be 'canonical' or 'stock', got '" + w + "'");
}

struct AccuracyOptions {
  SweepOptions sweep;
  std::vector<std::string> dts{"1/30", "1/60", "1/120", "1/240", "1/480"};
  std::vector<std::string> combos{"1/120x20", "1/240x20"};
  std::string default_dt = "1/60";
  std::string reference_dt = "1/960";
  std::string csv = "accuracy.csv";
  bool quick = false;
  bool no_ccd = false;
  bool no_floor = false;
  bool no_territories = false;
  CLI::Option* n_option = nullptr;
  CLI::Option* duration_option = nullptr;
};

int run_accuracy(AccuracyOptions& o) {
  SweepOptions& s = o.sweep;
  if (o.quick) {  // the CI-sized sweep (explicit --n / --duration win)
    if (o.n_option->count() == 0) s.sizes = {100};
    if (o.duration_option->count() == 0) s.duration = 2.0;
  }
  s.dts.clear();
  for (const std::string& d : o.dts) s.dts.push_back(parse_step_size(d));
  s.combos.clear();
  for (const std::string& c : o.combos) {
    const auto x = c.find('x');
    if (x == std::string::npos) throw std::invalid_argument("--combos: expected DTxITERATIONS, got '" + c + "'");
    s.combos.emplace_back(parse_step_size(c.substr(0, x)), std::stoi(c.substr(x + 1)));
  }
  s.default_dt = parse_step_size(o.default_dt);
  s.reference_dt = parse_step_size(o.reference_dt);
  if (o.no_ccd) s.ccd_axis = false;
  if (o.no_floor) s.floor_row = false;
  if (o.no_territories) s.territories.clear();
  if (s.sibling.empty()) s.sibling = default_sibling_binary();
  // Trace files of the other precision's runs: a private temporary folder.
  char tmpl[] = "/tmp/soda-accuracy-XXXXXX";
  if (!::mkdtemp(tmpl)) throw std::runtime_error("cannot create a temporary folder under /tmp");
  s.work_dir = tmpl;
  if (!s.reference_dir.empty()) std::filesystem::create_directories(s.reference_dir);

  std::ofstream csv(o.csv, std::ios::trunc);
  if (!csv) throw std::runtime_error(o.csv + ": cannot open for writing");
  csv << sweep_csv_header() << '\n' << std::flush;
  int not_ok = 0;
  std::vector<SweepRow> rows;
  try {
    rows = run_accuracy_sweep(s, [&](const SweepRow& r) {
      csv << sweep_csv_row(r) << '\n' << std::flush;
      if (r.status != "ok") ++not_ok;
    });
  } catch (...) {
    std::filesystem::remove_all(s.work_dir);
    throw;
  }
  std::filesystem::remove_all(s.work_dir);
  // Summary: the rows people look at first.
  std::printf("%-14s %-12s %-22s %10s %8s %11s %11s %11s %10s %5s  %s\n", "scene", "axis", "value", "wall_s",
              "ratio", "traj_rms_m", "pen_max_m", "pen_mean_m", "com_err_m", "lost", "status");
  for (const SweepRow& r : rows) {
    if (r.has_errors)
      std::printf("%-14s %-12s %-22s %10.3f %8.2f %11.4g %11.4g %11.4g %10.4g %5d  %s\n", r.scene.c_str(),
                  r.axis.c_str(), r.value.c_str(), r.wall_seconds, r.cost_vs_default, r.errors.traj_rms,
                  r.errors.pen_max, r.errors.pen_mean, r.errors.com_err, r.errors.lost_bodies, r.status.c_str());
    else
      std::printf("%-14s %-12s %-22s %s: %s\n", r.scene.c_str(), r.axis.c_str(), r.value.c_str(), r.status.c_str(),
                  r.note.c_str());
  }
  std::printf("wrote %s (%zu rows, %d not ok). Plot: /usr/bin/python3 bench/plot_accuracy.py %s OUT.png\n", o.csv.c_str(),
              rows.size(), not_ok, o.csv.c_str());
  const int status = sweep_exit_status(rows);
  if (status != 0)
    std::fprintf(stderr, "soda: error: bench accuracy: a territories row's state hash differs from the "
                         "one-territory run's (status '%s')\n", kSweepHashDiffers);
  return status;
}

struct TraceOptions {
  TraceRequest request;
  std::string dt = "1/60";
  std::string world = "canonical";
  std::string out;
};

int run_trace(TraceOptions& o) {
  o.request.dt = parse_step_size(o.dt);
  o.request.world = parse_world(o.world);
  const Trace t = record_request(o.request);
  write_trace(t, o.out);
  std::printf("%s %s: %d steps in %.3f s, state_hash %s -> %s\n", kPrecisionName, o.world.c_str(), t.steps,
              t.wall_seconds, hash_hex(t.state_hash).c_str(), o.out.c_str());
  return 0;
}

struct AnalyticOptions {
  std::string world = "canonical";
  bool one_world = false;
  std::string csv;
};


int run_analytic(const AnalyticOptions& o) {
  const auto runs = soda::run_analytic(parse_world(o.world), !o.one_world);
  int failed = 0;
  std::size_t checks = 0;
  std::printf("%s world, %s precision\n", o.world.c_str(), kPrecisionName);
  for (const AnalyticRun& r : runs) {
    if (r.territories > 1) {
      std::printf("%s on %s (%d territories, canonical world): %s\n", r.scene.c_str(), r.partition.c_str(),
                  r.territories, r.borders.c_str());
      std::printf("     state_hash %s, 1 territory %s after %d steps; %s%s\n", hash_hex(r.state_hash).c_str(),
                  hash_hex(r.one_territory_hash).c_str(), r.steps, r.mechanism.c_str(),
                  r.mechanism_fired ? "" : " -- FAIL: the borders are not crossed");
      if (!r.mechanism_fired) ++failed;
      if (r.first_divergent_step >= 0)
        std::printf("     FAIL: the state hash first differs from 1 territory's at step %d\n", r.first_divergent_step);
    }
    for (const AnalyticCheck& c : r.checks) {
      std::printf("%-4s %-15s %-52s %11.4g <= %-11.4g %s\n", c.pass ? "ok" : "FAIL", c.scene.c_str(),
                  c.quantity.c_str(), c.measured, c.tolerance, c.unit.c_str());
      if (!c.pass) ++failed;
      ++checks;
    }
  }
  if (!o.csv.empty()) {
    std::ofstream out(o.csv, std::ios::trunc);
    if (!out) throw std::runtime_error(o.csv + ": cannot open for writing");
    out << "scene,quantity,world,precision,measured,tolerance,unit,result,reason,"
           "territories,partition,steps,state_hash,one_territory_hash,migrations_out,ghosts_sent,border_islands,"
           "mechanism\n";
    for (const AnalyticRun& r : runs)
      for (const AnalyticCheck& c : r.checks) {
        out << c.scene << ',' << csv_field(c.quantity) << ',' << world_kind_name(r.world) << ',' << kPrecisionName
            << ',' << c.measured << ',' << c.tolerance << ',' << c.unit << ',' << (c.pass ? "pass" : "FAIL") << ','
            << csv_field(c.reason) << ',' << r.territories << ',' << r.partition << ',' << r.steps << ','
            << hash_hex(r.state_hash) << ',' << hash_hex(r.one_territory_hash) << ',';
        if (r.territories > 1)
          out << r.total.migrations_out << ',' << r.total.ghosts_sent << ',' << r.total.islands_solved << ','
              << csv_field(r.mechanism);
        else
          out << ",,,";
        out << '\n';
      }
  }
  std::printf("%zu checks, %d failed\n", checks, failed);
  return failed == 0 ? 0 : 1;
}

}  // namespace

std::vector<Command> add_accuracy_commands(CLI::App& bench) {
  std::vector<Command> out;

  auto a = std::make_shared<AccuracyOptions>();
  CLI::App* acc = bench.add_subcommand(
      "accuracy", "Run time vs error: vary step, iterations, precision, CCD, territories one at a time");
  SweepOptions& s = a->sweep;
  acc->add_option("--scenes", s.scenes, "Scenes to sweep")->delimiter(',')->capture_default_str();
  a->n_option = acc->add_option("--n", s.sizes, "Scene size per scene (one value: every scene)")->delimiter(',')->capture_default_str();
  acc->add_option("--seed", s.seed, "Scene seed")->capture_default_str();
  a->duration_option = acc->add_option("--duration", s.duration, "Simulated seconds per run")->capture_default_str();
  acc->add_option("--horizon", s.horizon, "Short-horizon window for the trajectory error, s")->capture_default_str();
  acc->add_option("--sample-period", s.sample_period, "Sampling period, s (a whole number of steps of every dt)")
      ->capture_default_str();
  acc->add_option("--default-dt", a->default_dt, "Default step (1/60 or seconds)")->capture_default_str();
  acc->add_option("--default-iterations", s.default_iterations, "Default solver iterations")->capture_default_str();
  acc->add_option("--dts", a->dts, "Step-size axis")->delimiter(',')->capture_default_str();
  acc->add_option("--iterations", s.iterations, "Iterations axis")->delimiter(',')->capture_default_str();
  acc->add_option("--precisions", s.precisions, "Precision axis (float, double)")->delimiter(',')->capture_default_str();
  acc->add_option("--territories", s.territories, "Territories axis")->delimiter(',')->capture_default_str();
  acc->add_option("--combos", a->combos, "Extra (dt x iterations) points, e.g. 1/240x20")->delimiter(',')
      ->capture_default_str();
  acc->add_option("--reference-dt", a->reference_dt, "Reference step")->capture_default_str();
  acc->add_option("--reference-iterations", s.reference_iterations, "Reference solver iterations")
      ->capture_default_str();
  acc->add_option("--reference-precision", s.reference_precision, "Reference precision")
      ->check(CLI::IsMember({"float", "double"}))
      ->capture_default_str();
  acc->add_option("--reference-dir", s.reference_dir, "Cache reference traces here and reuse them");
  acc->add_option("--profile-cell", s.metrics.profile_cell, "Height-profile cell edge, m")->capture_default_str();
  acc->add_option("--sibling", s.sibling, "The other precision's binary (default: next to this one)");
  acc->add_flag("--no-ccd", a->no_ccd, "Leave out the CCD axis");
  acc->add_flag("--no-floor", a->no_floor, "Leave out the floor row (reference settings in the other precision)");
  acc->add_flag("--no-territories", a->no_territories, "Leave out the territories axis");
  acc->add_flag("--quick", a->quick, "CI size: n = 100, 2 s simulated");
  acc->add_option("--csv", a->csv, "Output CSV")->capture_default_str();
  out.push_back({acc, [a] { return run_accuracy(*a); }});

  auto t = std::make_shared<TraceOptions>();
  CLI::App* tr = bench.add_subcommand(
      "accuracy-trace", "One traced run written to a trace file (what `bench accuracy` spawns in the other precision)");
  tr->add_option("--scene", t->request.scene, "Registry scene or .json file")->required();
  tr->add_option("--n", t->request.n, "Scene size")->capture_default_str();
  tr->add_option("--seed", t->request.seed, "Scene seed")->capture_default_str();
  tr->add_flag("--random-scale", t->request.random_scale, "falling-cubes: random edges");
  tr->add_option("--dt", t->dt, "Step (1/60 or seconds)")->capture_default_str();
  tr->add_option("--iterations", t->request.iterations, "Solver iterations")->capture_default_str();
  tr->add_option("--steps", t->request.steps, "Steps")->capture_default_str();
  tr->add_option("--world", t->world, "canonical | stock")->capture_default_str();
  tr->add_flag("--ccd", t->request.ccd, "CCD on every dynamic body (stock world only)");
  tr->add_option("--sample-period", t->request.sample_period, "Sampling period, s")->capture_default_str();
  tr->add_option("--horizon", t->request.horizon, "Short horizon, s")->capture_default_str();
  tr->add_option("--out", t->out, "Trace file to write")->required();
  out.push_back({tr, [t] { return run_trace(*t); }});

  auto an = std::make_shared<AnalyticOptions>();
  CLI::App* ana = bench.add_subcommand("analytic", "The analytic scenes against their closed forms, with tolerances");
  ana->add_option("--world", an->world, "canonical | stock (of the one-world runs; partitioned runs are canonical)")
      ->capture_default_str();
  ana->add_flag("--one-world", an->one_world, "Leave out the partitioned runs (borders across the motion)");
  ana->add_option("--csv", an->csv, "Also write the checks as CSV");
  out.push_back({ana, [an] { return run_analytic(*an); }});
  return out;
}

double parse_step_size(const std::string& text) {
  try {
    std::size_t used = 0;
    if (text.rfind("1/", 0) == 0) {
      const double d = std::stod(text.substr(2), &used);
      if (used == text.size() - 2 && d > 0) return 1.0 / d;
    } else {
      const double v = std::stod(text, &used);
      if (used == text.size() && v > 0) return v;
    }
  } catch (const std::exception&) {
  }
  throw std::invalid_argument("not a step size: '" + text + "' (use 1/60 or 0.0166)");
}

}  // namespace soda::cli
