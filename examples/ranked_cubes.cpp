// Territories on MPI ranks from an application's own program (docs/mpi.md):
// falling cubes on 4 territories, spread over the ranks of `mpirun -np R`
// (every rank runs the same program, run_scene with an MPI process group,
// and steps its share of the worlds), built against the installed package's
// soda::mpi. Rank 0 holds the whole scene's result and checks it against
// the threaded one-territory run (exit 1 if the hashes differ). Started
// without mpirun it runs the 4 territories on threads.
// Usage: mpirun -np 2 ranked_cubes [CUBES] [STEPS]   (default 500 cubes, 120 steps)
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>

#include "soda/mpi/mpi_group.h"
#include "soda/mpi/mpi_session.h"
#include "soda/runtime/run.h"

int main(int argc, char** argv) {
  std::optional<soda::MpiSession> mpi;
  try {
    if (soda::MpiSession::launched_by_mpirun()) mpi.emplace(&argc, &argv);
    const int cubes = argc > 1 ? std::atoi(argv[1]) : 500;
    const int steps = argc > 2 ? std::atoi(argv[2]) : 120;
    if (cubes < 1 || steps < 1) {
      std::fprintf(stderr, "usage: ranked_cubes [CUBES >= 1] [STEPS >= 1]\n");
      return 2;
    }
    const soda::Scene scene = soda::make_scene("falling-cubes", {cubes, 1});
    soda::RunConfig config;
    config.steps = steps;
    config.territories = 4;
    if (mpi) config.group = soda::make_mpi_group();  // collective: every rank, here
    const soda::RunResult ranked = soda::run_scene(scene, config);
    if (mpi && mpi->rank() != 0) return 0;  // its worlds' share is in rank 0's result

    soda::RunConfig one;
    one.steps = steps;
    const soda::RunResult reference = soda::run_scene(scene, one);
    std::printf("%d cubes, %d steps, 4 territories on %d rank%s: state hash %016llx, one territory %016llx: %s\n",
                cubes, steps, mpi ? mpi->size() : 1, mpi && mpi->size() > 1 ? "s" : "",
                static_cast<unsigned long long>(ranked.state_hash),
                static_cast<unsigned long long>(reference.state_hash),
                ranked.state_hash == reference.state_hash ? "equal" : "DIFFERENT");
    return ranked.state_hash == reference.state_hash ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "ranked_cubes: %s\n", e.what());
    if (mpi) mpi->abort(1);  // the other ranks may wait on this one: end the job
    return 1;
  }
}
