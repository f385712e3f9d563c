// `soda replay-info FILE`: what a replay file holds (docs/replay-format.md).
#include <cstdio>
#include <map>
#include <string>

#include "commands.h"
#include "soda/replay/replay_reader.h"
#include "soda/worlds/body_state.h"

namespace soda::cli {

Command add_replay_info_command(CLI::App& app) {
  auto path = std::make_shared<std::string>();
  CLI::App* cmd = app.add_subcommand("replay-info", "Show a replay file's header, frames and size (soda run --record)");
  cmd->add_option("file", *path, "The .replay file")->required();
  return {cmd, [path]() {
            replay::ReplayReader in(*path);
            const replay::ViewHeader& h = in.header();
            std::map<std::string, int> shapes;
            for (const replay::ViewBody& b : h.bodies)
              ++shapes[std::string(b.is_static ? "static " : "") + shape_kind_name(b.shape.kind)];
            std::string kinds;
            for (const auto& [name, count] : shapes) kinds += " " + std::to_string(count) + " " + name;
            std::printf("%s: SODA replay, format version %u, %llu bytes\n", path->c_str(), in.version(),
                        static_cast<unsigned long long>(in.file_bytes()));
            std::printf("  scene %s (seed %llu), dt %.6g s, %d territories, %zu bodies (%zu dynamic):%s\n",
                        h.scene.c_str(), static_cast<unsigned long long>(h.seed), h.dt, h.territories,
                        h.bodies.size(), h.dynamic_count(), kinds.c_str());
            if (!in.added_bodies().empty())
              std::printf("  bodies added during the run: %zu (ids %u .. %u), described in the file\n",
                          in.added_bodies().size(), in.added_bodies().front().id, in.added_bodies().back().id);
            std::printf("  grid: cells of %.4g m from (%.4g, %.4g, %.4g), map box (%d, %d, %d)..(%d, %d, %d), %lld cells\n",
                        h.grid.cell_size(), h.grid.origin().x(), h.grid.origin().y(), h.grid.origin().z(),
                        h.box.lo.x, h.box.lo.y, h.box.lo.z, h.box.hi.x, h.box.hi.y, h.box.hi.z,
                        static_cast<long long>(h.box.valid() ? h.box.count() : 0));
            const auto [first, last] = in.step_range();
            std::printf("  frames: %zu (steps %lld .. %lld), %zu keyframes (every %d frames or when a body leaves "
                        "the box)\n",
                        in.frame_count(), static_cast<long long>(first), static_cast<long long>(last),
                        in.keyframe_count(), in.keyframe_every());
            std::printf("  error: position <= %.3g mm (widest keyframe box), orientation <= %.3g rad\n",
                        in.position_error_bound() * 1e3, replay::kOrientationErrorBound);
            const double simulated = static_cast<double>(last - first) * h.dt;
            if (in.frame_count() > 1 && h.dynamic_count() > 0 && simulated > 0)
              std::printf("  size: %.0f bytes a frame, %.0f bytes per 1000 bodies per simulated second\n",
                          static_cast<double>(in.file_bytes()) / static_cast<double>(in.frame_count()),
                          static_cast<double>(in.file_bytes()) / (static_cast<double>(h.dynamic_count()) / 1000.0) /
                              simulated);
            if (in.frame_count() > 0) {
              const replay::ViewFrame f = *in.frame_at(last);
              std::size_t asleep = 0;
              for (std::uint8_t s : f.sleeping) asleep += s;
              std::printf("  last frame: step %lld, %zu bodies, %zu asleep, state_hash %s\n",
                          static_cast<long long>(f.step), f.sleeping.size(), asleep,
                          f.state_hash ? hash_hex(*f.state_hash).c_str() : "(none)");
            }
            return 0;
          }};
}

}  // namespace soda::cli
