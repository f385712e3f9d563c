// Internal: pinning a stepping thread to one core.
#pragma once

#include <string>

namespace soda {

/// Pins the calling thread to CPU (index mod n), where the n CPUs are the
/// ones this process may run on (sched_getaffinity, in ascending order).
/// Returns false, after logging a warning through spdlog naming `who`, if
/// that fails; pinning is an optimisation, never an error.
bool pin_current_thread(int index, const std::string& who);

/// Call on the thread that creates the threads to be pinned, before creating
/// them: initialises the logger they may warn through here, so that they do
/// not race to create it (spdlog's registry is a function-local static in
/// an uninstrumented library, whose guard ThreadSanitizer cannot see).
void prepare_thread_pinning();

}  // namespace soda
