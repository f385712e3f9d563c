// `soda bench accuracy`: the one-factor-at-a-time sweep (accuracy_sweep.h).
#include "soda/bench/accuracy_sweep.h"
#include "soda/bench/csv.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <sstream>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "soda/bench/accuracy_process.h"
#include "soda/scene/registry.h"
#include "soda/worlds/body_state.h"

namespace soda {
namespace {

// A configuration that cannot run here: its row says why.
struct NotAvailable : std::runtime_error {
  using std::runtime_error::runtime_error;
};

std::string num17(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}

std::string num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

// "1/60" for a step that is the inverse of a whole number, else the number.
std::string dt_label(double dt) {
  const double inv = 1.0 / dt;
  if (std::abs(inv - std::round(inv)) < 1e-9 * inv) return "1/" + std::to_string(std::lround(inv));
  return num(dt);
}

// dt for a file name: "960" for 1/960, else the number.
std::string file_label(double dt) {
  const std::string l = dt_label(dt);
  return l.rfind("1/", 0) == 0 ? l.substr(2) : num17(dt);
}


struct Config {
  double dt;
  int iterations;
  std::string precision;
  WorldKind world = WorldKind::Canonical;
  bool ccd = false;
  std::string key() const {
    return precision + "/" + world_kind_name(world) + (ccd ? "/ccd/" : "/-/") + num17(dt) + "/" + std::to_string(iterations);
  }
};

class SceneSweep {
 public:
  SceneSweep(const SweepOptions& o, const std::string& scene, int n) : o_(o), scene_name_(scene), n_(n) {
    base_.scene = scene;
    base_.n = n;
    base_.seed = o.seed;
    base_.sample_period = o.sample_period;
    base_.horizon = o.horizon;
    scene_ = request_scene(base_);
  }

  const Scene& scene() const { return scene_; }

  TraceRequest request(const Config& c) const {
    TraceRequest r = base_;
    r.dt = c.dt;
    r.iterations = c.iterations;
    r.steps = steps_for(o_.duration, c.dt);
    r.world = c.world;
    r.ccd = c.ccd;
    return r;
  }

  // The trace of a configuration, run once and kept.
  const Trace& trace(const Config& c, bool is_reference = false) {
    const std::string key = c.key();
    if (auto it = traces_.find(key); it != traces_.end()) return it->second;
    const TraceRequest r = request(c);
    std::string cache;
    if (is_reference && !o_.reference_dir.empty()) {
      cache = (std::filesystem::path(o_.reference_dir) /
               ("reference-" + scene_name_ + "-n" + std::to_string(n_) + "-seed" + std::to_string(o_.seed) + "-" +
                c.precision + "-dt" + file_label(c.dt) + "-it" + std::to_string(c.iterations) +
                "-T" + num(o_.duration) + "-h" + num(o_.horizon) + "-p" + num(o_.sample_period) + ".trace"))
                  .string();
      if (std::filesystem::exists(cache)) {
        Trace t = read_trace(cache);
        if (t.precision == c.precision && t.steps == r.steps && t.iterations == c.iterations && t.dt == c.dt) {
          spdlog::info("{}: reusing reference trace {}", scene_name_, cache);
          return traces_.emplace(key, std::move(t)).first->second;
        }
      }
    }
    spdlog::info("{} n={}: {} dt {} iterations {} {}{} ({} steps)", scene_name_, n_, c.precision, dt_label(c.dt),
                 c.iterations, world_kind_name(c.world), c.ccd ? " CCD" : "", r.steps);
    Trace t;
    if (c.precision == kPrecisionName) {
      t = record_request(r);
    } else {
      if (!is_executable(o_.sibling))
        throw NotAvailable("the " + c.precision + " build is a separate binary and none was found" +
                           (o_.sibling.empty() ? std::string() : " at " + o_.sibling) +
                           " (build with SODA_BUILD_DOUBLE=ON, or pass --sibling)");
      const std::string path =
          (std::filesystem::path(o_.work_dir) / ("trace-" + std::to_string(traces_.size()) + "-" + scene_name_ + ".trace"))
              .string();
      t = record_request_in(o_.sibling, r, path);
      std::filesystem::remove(path);
    }
    if (!cache.empty()) write_trace(t, cache);
    return traces_.emplace(key, std::move(t)).first->second;
  }

 private:
  const SweepOptions& o_;
  std::string scene_name_;
  int n_;
  TraceRequest base_;
  Scene scene_;
  std::map<std::string, Trace> traces_;
};

}  // namespace

int steps_for(double duration, double dt) {
  if (!(dt > 0)) throw std::invalid_argument("accuracy: dt must be > 0");
  return static_cast<int>(std::lround(duration / dt));
}

Scene request_scene(const TraceRequest& r) {
  SceneParams params;
  params.n = r.n;
  params.seed = r.seed;
  params.random_scale = r.random_scale;
  Scene scene = load_or_make_scene(r.scene, params);
  scene.settings.dt = r.dt;
  scene.settings.iterations = r.iterations;
  scene.settings.steps = r.steps;
  return scene;
}

Trace record_request(const TraceRequest& r) {
  const Scene scene = request_scene(r);
  TraceConfig c;
  c.world = r.world;
  c.steps = r.steps;
  c.ccd = r.ccd;
  c.sample_period = r.sample_period;
  c.horizon = r.horizon;
  return record_trace(scene, c);
}

Trace record_request_in(const std::string& binary, const TraceRequest& r, const std::string& trace_path) {
  std::vector<std::string> argv = {binary,
                                   "bench",
                                   "accuracy-trace",
                                   "--scene",
                                   r.scene,
                                   "--n",
                                   std::to_string(r.n),
                                   "--seed",
                                   std::to_string(r.seed),
                                   "--dt",
                                   num17(r.dt),
                                   "--iterations",
                                   std::to_string(r.iterations),
                                   "--steps",
                                   std::to_string(r.steps),
                                   "--world",
                                   world_kind_name(r.world),
                                   "--sample-period",
                                   num17(r.sample_period),
                                   "--horizon",
                                   num17(r.horizon),
                                   "--out",
                                   trace_path,
                                   "--log-level",
                                   "warn"};
  if (r.random_scale) argv.push_back("--random-scale");
  if (r.ccd) argv.push_back("--ccd");
  run_process(argv);
  return read_trace(trace_path);
}

std::vector<SweepRow> run_accuracy_sweep(const SweepOptions& o, const std::function<void(const SweepRow&)>& on_row) {
  if (o.sizes.empty() || (o.sizes.size() != 1 && o.sizes.size() != o.scenes.size()))
    throw std::invalid_argument("accuracy: give one size for every scene, or one size for all");
  std::vector<SweepRow> rows;
  for (std::size_t si = 0; si < o.scenes.size(); ++si) {
    const std::string& name = o.scenes[si];
    const int n = o.sizes.size() == 1 ? o.sizes[0] : o.sizes[si];
    SceneSweep sweep(o, name, n);
    const Config reference{o.reference_dt, o.reference_iterations, o.reference_precision};
    const Config def{o.default_dt, o.default_iterations, kPrecisionName};
    const Trace& ref = sweep.trace(reference, true);
    const Trace& def_trace = sweep.trace(def);

    auto base_row = [&](const std::string& axis, const std::string& value, const Config& c) {
      SweepRow row;
      row.scene = name;
      row.n = n;
      row.seed = o.seed;
      row.axis = axis;
      row.value = value;
      row.world = world_kind_name(c.world);
      row.precision = c.precision;
      row.dt = c.dt;
      row.iterations = c.iterations;
      row.ccd = c.ccd;
      row.steps = steps_for(o.duration, c.dt);
      row.horizon = o.horizon;
      row.ref_dt = o.reference_dt;
      row.ref_iterations = o.reference_iterations;
      row.ref_precision = o.reference_precision;
      return row;
    };
    auto emit = [&](SweepRow row) {
      spdlog::info("{} {}={}: wall {:.3f} s (x{:.2f}), traj_rms {:.4g} m, pen_max {:.4g} m, com_err {:.4g} m [{}{}{}]",
                   row.scene, row.axis, row.value, row.wall_seconds, row.cost_vs_default, row.errors.traj_rms,
                   row.errors.pen_max, row.errors.com_err, row.status, row.note.empty() ? "" : ": ", row.note);
      if (on_row) on_row(row);
      rows.push_back(std::move(row));
    };
    auto fill = [&](SweepRow& row, const Trace& t) {
      row.steps = t.steps;
      row.wall_seconds = t.wall_seconds;
      row.cost_vs_default = def_trace.wall_seconds > 0 ? t.wall_seconds / def_trace.wall_seconds : 0.0;
      row.state_hash = hash_hex(t.state_hash);
      row.sleeping = t.sleeping;
      row.errors = compare_traces(sweep.scene(), t, ref, o.metrics);
      row.has_errors = true;
      if (t.first_nonfinite_step >= 0) {
        row.status = "failed";
        row.note = "non-finite state at step " + std::to_string(t.first_nonfinite_step);
      }
    };
    auto config_row = [&](const std::string& axis, const std::string& value, const Config& c,
                          const std::string& note = {}) {
      SweepRow row = base_row(axis, value, c);
      row.note = note;
      try {
        fill(row, sweep.trace(c, axis == "reference"));
      } catch (const NotAvailable& e) {
        row.status = "not available";
        row.note = e.what();
      } catch (const std::exception& e) {
        row.status = "failed";
        row.note = e.what();
      }
      emit(std::move(row));
    };

    config_row("reference", "reference", reference, "the reference against itself: errors 0 by definition");
    if (o.floor_row) {
      const std::string other = o.reference_precision == "double" ? "float" : "double";
      config_row("floor", "reference settings, " + other,
                 Config{o.reference_dt, o.reference_iterations, other},
                 "rounding alone: the floor below which chaotic metrics (pile, final) cannot go");
    }
    config_row("default", "default", def);
    for (double dt : o.dts)
      config_row("dt", dt_label(dt), Config{dt, o.default_iterations, kPrecisionName});
    for (int it : o.iterations)
      config_row("iterations", std::to_string(it), Config{o.default_dt, it, kPrecisionName});
    for (const std::string& p : o.precisions)
      config_row("precision", p, Config{o.default_dt, o.default_iterations, p});
    if (o.ccd_axis) {
      config_row("ccd", "off (canonical)", def);
      config_row("ccd", "off (stock)", Config{o.default_dt, o.default_iterations, kPrecisionName, WorldKind::Stock});
      config_row("ccd", "on (stock)",
                 Config{o.default_dt, o.default_iterations, kPrecisionName, WorldKind::Stock, true},
                 "CCD is outside the canonical world's contract: stock Bullet world with CCD on every dynamic body");
    }
    for (const auto& [dt, it] : o.combos)
      config_row("combo", dt_label(dt) + " x " + std::to_string(it), Config{dt, it, kPrecisionName});

    // Territories: run_scene with K territories; its state hash against K = 1.
    if (!o.territories.empty()) {
      Scene scene = sweep.scene();
      scene.settings.dt = o.default_dt;
      scene.settings.iterations = o.default_iterations;
      RunConfig rc;
      rc.world = WorldKind::Canonical;
      rc.steps = steps_for(o.duration, o.default_dt);
      rc.progress_seconds = 0;
      rc.territories = 1;
      std::uint64_t hash1 = 0;
      bool have1 = false;
      try {
        hash1 = run_scene(scene, rc).state_hash;
        have1 = true;
      } catch (const std::exception& e) {
        spdlog::warn("{}: territories = 1 run failed: {}", name, e.what());
      }
      for (int k : o.territories) {
        SweepRow row = base_row("territories", std::to_string(k), def);
        row.territories = k;
        rc.territories = k;
        try {
          const RunResult r = run_scene(scene, rc);
          row.steps = r.steps;
          row.wall_seconds = r.wall_seconds;
          row.cost_vs_default = def_trace.wall_seconds > 0 ? r.wall_seconds / def_trace.wall_seconds : 0.0;
          row.state_hash = hash_hex(r.state_hash);
          row.sleeping = r.sleeping_bodies;
          const std::uint64_t against = k == 1 ? def_trace.state_hash : hash1;
          const char* what = k == 1 ? "the traced default run" : "territories = 1";
          if (!have1 && k != 1) {
            row.status = "failed";
            row.note = "no territories = 1 run to compare with";
          } else if (r.state_hash == against) {
            // Identical bits: every error metric equals the default row's.
            row.decomposition_error = "0";
            row.errors = compare_traces(sweep.scene(), def_trace, ref, o.metrics);
            row.has_errors = true;
            row.note = std::string("identical hash to ") + what + ": errors are the default row's";
          } else {
            // The exactness contract broken: the sweep fails (sweep_exit_status).
            row.status = kSweepHashDiffers;
            row.note = std::string("state hash differs from ") + what + " (" + hash_hex(against) +
                       "): decomposition error not zero; run_scene returns no states to measure it";
          }
        } catch (const std::invalid_argument& e) {
          row.status = "not available";
          row.note = e.what();
        } catch (const std::exception& e) {
          row.status = "failed";
          row.note = e.what();
        }
        emit(std::move(row));
      }
    }
  }
  return rows;
}

int sweep_exit_status(const std::vector<SweepRow>& rows) {
  for (const SweepRow& r : rows)
    if (r.status == kSweepHashDiffers) return 1;
  return 0;
}

std::string sweep_csv_header() {
  return "scene,n,seed,axis,value,world,precision,dt,iterations,ccd,territories,steps,wall_seconds,"
         "cost_vs_default,state_hash,sleeping,traj_rms_m,traj_max_m,angle_rms_rad,pen_max_m,pen_mean_m,"
         "energy_drift,energy_err,energy_gain,com_err_m,height_rms_m,top_err_m,final_rms_m,lost_bodies,ref_lost_bodies,"
         "decomposition_error,horizon_s,"
         "ref_dt,ref_iterations,ref_precision,status,note";
}

std::string sweep_csv_row(const SweepRow& r) {
  std::ostringstream s;
  auto err = [&](double v) { return r.has_errors ? num(v) : std::string(); };
  const bool ran = r.status != "not available";
  s << csv_field(r.scene) << ',' << r.n << ',' << r.seed << ',' << csv_field(r.axis) << ',' << csv_field(r.value)
    << ',' << r.world << ',' << r.precision << ',' << num17(r.dt) << ',' << r.iterations << ','
    << (r.ccd ? "on" : "off") << ',' << r.territories << ',' << r.steps << ','
    << (ran ? num(r.wall_seconds) : "") << ',' << (ran ? num(r.cost_vs_default) : "") << ',' << r.state_hash
    << ',' << (ran ? std::to_string(r.sleeping) : "") << ',' << err(r.errors.traj_rms) << ','
    << err(r.errors.traj_max) << ',' << err(r.errors.angle_rms) << ',' << err(r.errors.pen_max) << ','
    << err(r.errors.pen_mean) << ',' << err(r.errors.energy_drift) << ',' << err(r.errors.energy_err) << ',' << err(r.errors.energy_gain) << ','
    << err(r.errors.com_err) << ',' << err(r.errors.height_rms) << ',' << err(r.errors.top_err) << ','
    << err(r.errors.final_rms) << ',' << (r.has_errors ? std::to_string(r.errors.lost_bodies) : "") << ','
    << (r.has_errors ? std::to_string(r.errors.ref_lost_bodies) : "") << ',' << r.decomposition_error << ',' << num(r.horizon) << ',' << num17(r.ref_dt)
    << ',' << r.ref_iterations << ',' << r.ref_precision << ',' << csv_field(r.status) << ','
    << csv_field(r.note);
  return s.str();
}

}  // namespace soda
