#include "execution/thread_pinning.h"

#include <pthread.h>
#include <sched.h>

#include <cstring>
#include <vector>

#include <spdlog/spdlog.h>

namespace soda {

bool pin_current_thread(int index, const std::string& who) {
  cpu_set_t allowed;
  CPU_ZERO(&allowed);
  if (sched_getaffinity(0, sizeof allowed, &allowed) != 0) {
    spdlog::warn("{}: not pinned (sched_getaffinity: {})", who, std::strerror(errno));
    return false;
  }
  std::vector<int> cpus;
  for (int c = 0; c < CPU_SETSIZE; ++c)
    if (CPU_ISSET(c, &allowed)) cpus.push_back(c);
  if (cpus.empty() || index < 0) {
    spdlog::warn("{}: not pinned (no CPU available)", who);
    return false;
  }
  const int cpu = cpus[static_cast<std::size_t>(index) % cpus.size()];
  cpu_set_t one;
  CPU_ZERO(&one);
  CPU_SET(cpu, &one);
  const int rc = pthread_setaffinity_np(pthread_self(), sizeof one, &one);
  if (rc != 0) {
    spdlog::warn("{}: not pinned to CPU {} (pthread_setaffinity_np: {})", who, cpu, std::strerror(rc));
    return false;
  }
  spdlog::debug("{}: pinned to CPU {}", who, cpu);
  return true;
}

void prepare_thread_pinning() { spdlog::default_logger_raw(); }

}  // namespace soda
