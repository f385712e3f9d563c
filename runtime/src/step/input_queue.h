// Internal: the user inputs of a Simulation, by (step, sequence). The API
// thread adds; every world reads the inputs of the boundary it is at before
// it begins the next step (each applies those that concern its territory).
// Inputs are kept for the whole run: a rollback re-applies them.
#pragma once

#include <algorithm>
#include <cstdint>
#include <mutex>
#include <tuple>
#include <vector>

#include "soda/runtime/user_input.h"

namespace soda {

class InputQueue {
 public:
  void add(UserInput input) {
    std::lock_guard lock(mutex_);
    const auto key = [](const UserInput& i) { return std::make_tuple(i.step, i.sequence); };
    auto at = inputs_.begin();
    while (at != inputs_.end() && key(*at) < key(input)) ++at;
    newest_step_ = std::max(newest_step_, input.step);
    inputs_.insert(at, std::move(input));
  }
  /// The inputs at boundary `step`, in sequence order (usually none: a
  /// quick check first).
  std::vector<UserInput> at(std::int64_t step) const {
    std::lock_guard lock(mutex_);
    std::vector<UserInput> out;
    if (step > newest_step_) return out;
    for (const UserInput& i : inputs_)
      if (i.step == step) out.push_back(i);
    return out;
  }
  /// The inputs at boundary `step` and after, in (step, sequence) order.
  std::vector<UserInput> from(std::int64_t step) const {
    std::lock_guard lock(mutex_);
    std::vector<UserInput> out;
    for (const UserInput& i : inputs_)
      if (i.step >= step) out.push_back(i);
    return out;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<UserInput> inputs_;
  std::int64_t newest_step_ = -1;
};

}  // namespace soda
