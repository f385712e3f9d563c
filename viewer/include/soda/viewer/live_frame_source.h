// viewer/ — the FrameSource of a running Simulation (`soda run --serve`).
//
// A pump thread of its own reads the Simulation through one SceneReader
// with try_read_at at the newest published step, about every kPumpPeriod,
// and keeps only the newest frame. The reader's cursor thus never lags
// more than one pump period behind the worlds, so the worlds are held back
// only if they fill their whole transform buffers (SimulationConfig::
// buffer_capacity steps) within one pump period — never by the browser,
// whose requests (newest_after) only copy the kept frame under a mutex.
// Steps between two pumps are skipped (the viewer shows the newest).
//
// A frame holds the bodies alive at its step (view_frame: ids when they
// are not the header's); a body an input adds is drawn once described
// (describe(), before or while the run goes). Owners, sleep flags and busy
// times are the worlds' own (SceneFrame); cell_owner is the run's map (a
// Simulation has no load balancing), sent with every frame.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "soda/grid/territory_map.h"
#include "soda/replay/view_frame.h"
#include "soda/runtime/simulation.h"

namespace soda::viewer {

/// How often the pump reads the worlds: 60 Hz, a display's rate.
inline constexpr std::chrono::milliseconds kPumpPeriod{16};

/// A SceneFrame as the viewer's frame: soda::view_frame (runtime/
/// view_adapter.h: the worlds' own owners, sleep flags and busy times; ids
/// when the bodies are not the header's) with cell_owner = `cell_owner`.
/// Pure function.
replay::ViewFrame to_view_frame(const SceneFrame& frame, const replay::ViewHeader& header,
                                const std::vector<std::uint16_t>& cell_owner);

/// A running Simulation as a FrameSource. Thread safety: the FrameSource
/// members from any thread; start/finish/the destructor from the owner's.
class LiveFrameSource : public replay::FrameSource {
 public:
  /// `sim` must outlive this object (or finish() be called first); `map` is
  /// the map sim was built with. Adds a reader to sim and keeps the frame of
  /// step 0 if the worlds have not moved past it; the pump starts with
  /// start().
  LiveFrameSource(Simulation& sim, const Scene& scene, TerritoryMap map);
  /// Stops the pump (and drops the reader).
  ~LiveFrameSource() override;

  /// Starts the pump thread.
  void start();
  /// Describes a body an input adds (Simulation::add_body), so that a
  /// viewer can draw it when a frame holds it (body()). Any thread.
  void describe(const Body& body);
  /// The run is over: stops the pump, reads the frame of `last_step`
  /// (waiting for it; the worlds must publish it) and keeps it with
  /// `state_hash`; finished() is then true.
  void finish(std::int64_t last_step, std::uint64_t state_hash);

  const replay::ViewHeader& header() const override { return header_; }
  std::optional<replay::ViewFrame> newest_after(std::int64_t after) override;
  /// Only the newest frame is held (a live run keeps no history).
  std::optional<replay::ViewFrame> frame_at(std::int64_t step) override;
  std::pair<std::int64_t, std::int64_t> step_range() const override;
  bool finished() const override;
  std::optional<replay::ViewBody> body(BodyId id) const override;

  /// Frames the pump has read so far (tests: the pump runs).
  std::int64_t frames_read() const { return frames_read_.load(); }
  /// Why the pump stopped early (a world failed; the run reports it too),
  /// empty if it did not.
  std::string pump_error() const;

 private:
  void pump();       // the pump thread: pump_loop, its error kept
  void pump_loop();
  void stop_pump();
  void keep(replay::ViewFrame frame);

  Simulation& sim_;
  const replay::ViewHeader header_;
  const TerritoryMap map_;
  std::vector<std::uint16_t> cell_owner_;  // the map's owners, sent with every frame
  SceneReader reader_;                     // pump thread (then finish's)
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<std::int64_t> frames_read_{0};

  mutable std::mutex mutex_;
  std::optional<replay::ViewFrame> newest_;
  std::map<BodyId, replay::ViewBody> described_;
  bool finished_ = false;
  std::string pump_error_;
};

}  // namespace soda::viewer
