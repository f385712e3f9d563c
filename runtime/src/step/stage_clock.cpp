#include "step/stage_clock.h"

#include "soda/loadbalance/thread_clock.h"

namespace soda {
namespace {

// The world whose clock last opened on this thread: a thread that runs
// several worlds (round-robin, a pool) has no CPU time of one world alone.
thread_local const StageClock* t_last_opened = nullptr;

}  // namespace

const char* stage_name(Stage stage) {
  switch (stage) {
    case Stage::Predict: return "predict";
    case Stage::ExchangeGhosts: return "exchange_ghosts";
    case Stage::Collide: return "collide";
    case Stage::BuildIslands: return "build_islands";
    case Stage::Glue: return "glue";
    case Stage::Merge: return "merge";
    case Stage::Solve: return "solve";
    case Stage::Integrate: return "integrate";
    case Stage::Migrate: return "migrate";
    case Stage::Publish: return "publish";
    case Stage::Receive: return "receive";
    case Stage::Checkpoint: return "checkpoint";
    case Stage::Rollback: return "rollback";
    case Stage::Idle: return "idle";
  }
  return "unknown";
}

StageClock::Scope::Scope(StageClock& clock, Stage stage) : clock_(clock), previous_(clock.current_) {
  if (clock.depth_ > 0 && stage == clock.current_) {
    same_ = true;
    ++clock.depth_;
    return;
  }
  const std::int64_t now = thread_cpu_ns();
  if (clock.depth_++ == 0) {
    if (clock.thread_first_ns_ < 0) {
      clock.thread_first_ns_ = now;
      clock.thread_ = std::this_thread::get_id();
    } else if (clock.thread_ != std::this_thread::get_id() || t_last_opened != &clock) {
      clock.shared_ = true;
    }
    t_last_opened = &clock;
    previous_ = Stage::Idle;
  } else {
    clock.close_interval(now);
  }
  clock.mark_ = now;
  clock.current_ = stage;
}

StageClock::Scope::~Scope() {
  if (!same_) clock_.close_interval(thread_cpu_ns());
  clock_.current_ = previous_;
  --clock_.depth_;
}

void StageClock::close_interval(std::int64_t now) {
  totals_.cpu_ns[index(current_)] += now - mark_;
  totals_.cpu_ns_sum += now - mark_;
  mark_ = now;
}

std::int64_t StageClock::cpu_ns_now() {
  close_interval(thread_cpu_ns());
  return totals_.cpu_ns_sum;
}

void StageClock::publish() {
  const std::int64_t now = thread_cpu_ns();
  close_interval(now);
  totals_.thread_cpu_ns = shared_ ? 0 : now - thread_first_ns_;
  published_ = totals_;
  tally_.end_step();
  published_traffic_ = tally_.totals();
}

}  // namespace soda
