// mpi/ — SODA over MPI ranks (docs/mpi.md): the territories of one run on
// several processes, same state hash. This header: MPI's lifetime.
//
//   int main(int argc, char** argv) {
//     std::optional<soda::MpiSession> mpi;
//     if (soda::MpiSession::launched_by_mpirun()) mpi.emplace(&argc, &argv);
//     ...  // soda::make_mpi_group() (mpi_group.h) into RunConfig::group
//   }
//
// Thread safety: MPI is initialised at MPI_THREAD_FUNNELED: every MPI call
// (the group's pump and gathers) on the thread that made the session; the
// world threads never call MPI.
#pragma once

namespace soda {

class MpiSession {
 public:
  /// MPI_Init_thread at MPI_THREAD_FUNNELED; throws std::runtime_error if
  /// the library provides less, or if MPI is already initialised.
  MpiSession(int* argc, char*** argv);
  /// MPI_Finalize (unless abort() ran).
  ~MpiSession();
  MpiSession(const MpiSession&) = delete;
  MpiSession& operator=(const MpiSession&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  /// Ends every rank of the job now (MPI_Abort with `code`): after a
  /// failure, when a rank cannot count on the others reaching
  /// MPI_Finalize. Does not return.
  [[noreturn]] void abort(int code);

  /// True when this process was started by an MPI launcher (mpirun,
  /// mpiexec, srun): Open MPI's OMPI_COMM_WORLD_SIZE, PMIx's PMIX_RANK or
  /// PMI's PMI_SIZE in the environment. A plain `soda run` stays a
  /// single-process run and never initialises MPI.
  static bool launched_by_mpirun();

 private:
  int rank_ = 0;
  int size_ = 1;
};

}  // namespace soda
