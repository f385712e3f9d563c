// loadbalance/ — load metrics and (later) the cession policy.
// This header: per-thread CPU time, the thesis' load measure for discrete
// steps (time a world's thread actually computed, not wall time).
#pragma once

#include <cstdint>

namespace soda {

/// CPU time consumed so far by the calling thread (CLOCK_THREAD_CPUTIME_ID),
/// in nanoseconds. Thread-safe; meaningful only on the thread that calls it.
std::int64_t thread_cpu_ns();

/// CPU time consumed so far by the whole process, every thread
/// (CLOCK_PROCESS_CPUTIME_ID), in nanoseconds. Thread-safe.
std::int64_t process_cpu_ns();

/// Monotonic wall clock in nanoseconds (CLOCK_MONOTONIC). Thread-safe.
std::int64_t wall_ns();

}  // namespace soda
