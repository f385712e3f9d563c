// Internal: the few MPI handles the MPI transport and group own, as RAII
// types over the raw C API (no C++ bindings: Open MPI dropped them), and
// the one error check every call goes through.
//
// Thread safety: MPI runs at MPI_THREAD_FUNNELED (mpi_session.h): every
// call below, destructors included, on the thread that initialised MPI.
#pragma once

#include <mpi.h>

#include <stdexcept>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace soda::mpi {

/// Throws std::runtime_error naming `call` and MPI's own text unless
/// `code` is MPI_SUCCESS (the communicators use MPI_ERRORS_RETURN).
inline void check(int code, const char* call) {
  if (code == MPI_SUCCESS) return;
  char text[MPI_MAX_ERROR_STRING];
  int length = 0;
  MPI_Error_string(code, text, &length);
  throw std::runtime_error(std::string("MPI: ") + call + " failed: " + std::string(text, static_cast<std::size_t>(length)));
}

/// A duplicate of a communicator (its own message space: messages of one
/// transport never match receives of another), freed on destruction.
/// Construction is collective over `parent`.
class Communicator {
 public:
  explicit Communicator(MPI_Comm parent) {
    check(MPI_Comm_dup(parent, &comm_), "MPI_Comm_dup");
    check(MPI_Comm_set_errhandler(comm_, MPI_ERRORS_RETURN), "MPI_Comm_set_errhandler");
  }
  ~Communicator() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (!finalized && comm_ != MPI_COMM_NULL) MPI_Comm_free(&comm_);
  }
  Communicator(const Communicator&) = delete;
  Communicator& operator=(const Communicator&) = delete;
  MPI_Comm get() const { return comm_; }
  int rank() const {
    int r = 0;
    check(MPI_Comm_rank(comm_, &r), "MPI_Comm_rank");
    return r;
  }
  int size() const {
    int n = 0;
    check(MPI_Comm_size(comm_, &n), "MPI_Comm_size");
    return n;
  }

 private:
  MPI_Comm comm_ = MPI_COMM_NULL;
};

/// A non-blocking send and the bytes it sends (which must outlive it).
/// Destroyed unfinished: cancelled and freed (a run that stopped early).
class PendingSend {
 public:
  PendingSend(std::vector<std::uint8_t> bytes, int to, int tag, MPI_Comm comm) : bytes_(std::move(bytes)) {
    check(MPI_Isend(bytes_.data(), static_cast<int>(bytes_.size()), MPI_BYTE, to, tag, comm, &request_), "MPI_Isend");
  }
  ~PendingSend() {
    int finalized = 0;
    MPI_Finalized(&finalized);
    if (finalized || request_ == MPI_REQUEST_NULL) return;
    MPI_Cancel(&request_);
    MPI_Request_free(&request_);
  }
  PendingSend(const PendingSend&) = delete;
  PendingSend& operator=(const PendingSend&) = delete;
  /// True once the send is complete (the request is then released).
  bool done() {
    if (request_ == MPI_REQUEST_NULL) return true;
    int flag = 0;
    check(MPI_Test(&request_, &flag, MPI_STATUS_IGNORE), "MPI_Test");
    return flag != 0;
  }

 private:
  std::vector<std::uint8_t> bytes_;
  MPI_Request request_ = MPI_REQUEST_NULL;
};

}  // namespace soda::mpi
