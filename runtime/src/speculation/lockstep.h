// Internal: the Speculation of a world that never runs ahead (speculation.h):
// it waits for every neighbour's message of a step, so it never bets and
// never goes back. Every hook's verdict is empty and every message is
// accepted; what it does is what a lockstep world does at its scene step
// boundaries — keep its state when asked to (ProcessSafety::keep_states,
// the watchdog's heal and a Simulation's past inputs), report its clock to
// the commit horizon, hand its validation reports on at once, and under a
// Simulation commit the entries no rollback can change.
#pragma once

#include "step/kept_states.h"
#include "step/process_options.h"
#include "speculation/speculation.h"
#include "step/stage_clock.h"

namespace soda {

class Lockstep final : public Speculation {
 public:
  struct Context {
    const WorldStep& step;
    KeptStates& kept;
    const ProcessSafety& safety;
    const ProcessOutput& output;
    Validator* validator;
    int substeps;
    StageClock& clock;
  };
  explicit Lockstep(Context context) : c_(context) {}

  Verdict catch_up() override { return {}; }
  Verdict screen(Message&) override { return {}; }
  Verdict bet(MessageKind) override { return {}; }
  Verdict before_predict() override { return {}; }
  void used(const MessageKey&, const Message&) override {}
  void sent(const Message&) override {}
  void merged() override {}
  void report(WorldStepReport report) override;
  /// At a scene step boundary: keeps the state (keep_states), reports the
  /// clock to the commit horizon and drops the states GVT passed.
  Verdict step_ended(const TerritoryCounters&) override;
  bool done() override { return true; }
  bool wake_when_final(std::int64_t) override { return false; }
  /// Commits the entries below the commit horizon (every one without kept
  /// states) and tells the RunControl.
  void published(std::int64_t scene_step) override;
  void report_committed() override {}
  void step_cpu(std::int64_t) override {}
  void reset(std::int64_t) override {}
  std::uint32_t epoch() const override { return 0; }
  bool runs_ahead() const override { return false; }
  void metrics(WorldMetrics&) const override {}

 private:
  Context c_;
};

}  // namespace soda
