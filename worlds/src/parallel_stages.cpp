#include "parallel_stages.h"

#include <algorithm>

#include "soda/worlds/solver_pool.h"

namespace soda {

int run_in_chunks(SolverPool* pool, int count, int min_count, int chunk,
                  const std::function<void(int, int)>& fn) {
  if (count <= 0) return 1;
  if (!pool || pool->threads() < 2 || count < min_count) {
    fn(0, count);
    return 1;
  }
  const int tasks = (count + chunk - 1) / chunk;
  return pool->run(tasks, [&](int t) { fn(t * chunk, std::min(count, (t + 1) * chunk)); });
}

}  // namespace soda
