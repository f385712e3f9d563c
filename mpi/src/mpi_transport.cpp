#include "mpi_transport.h"

#include <chrono>
#include <climits>
#include <stdexcept>
#include <thread>

#include "soda/runtime/message_codec.h"

namespace soda::mpi {

MpiTransport::MpiTransport(MPI_Comm parent, std::vector<int> rank_of_world, std::unique_ptr<Transport> local)
    : comm_(parent), rank_(comm_.rank()), rank_of_world_(std::move(rank_of_world)), local_(std::move(local)) {}

MpiTransport::~MpiTransport() = default;  // unfinished sends are cancelled (PendingSend)

void MpiTransport::send(WorldId to, Message message) {
  if (to < 0 || static_cast<std::size_t>(to) >= rank_of_world_.size())
    throw std::out_of_range("MpiTransport: no world " + std::to_string(to));
  const int rank = rank_of_world_[static_cast<std::size_t>(to)];
  if (rank == rank_) {
    local_->send(to, std::move(message));
    return;
  }
  if (message.to != to) throw std::invalid_argument("Transport::send: message.to differs from the receiver");
  Outgoing out{rank, encode_message(message)};
  if (out.bytes.size() > static_cast<std::size_t>(INT_MAX))
    throw std::length_error("MpiTransport: a message of " + std::to_string(out.bytes.size()) +
                            " bytes, more than one MPI send carries (" + describe(message) + ")");
  out_messages_.fetch_add(1, std::memory_order_relaxed);
  out_bytes_.fetch_add(out.bytes.size(), std::memory_order_relaxed);
  {
    std::lock_guard lock(mutex_);
    outbox_.push_back(std::move(out));
  }
  queued_.notify_one();
}

bool MpiTransport::progress() {
  bool moved = false;
  std::deque<Outgoing> batch;
  {
    std::lock_guard lock(mutex_);
    batch.swap(outbox_);
  }
  for (Outgoing& o : batch) {
    pending_.push_back(std::make_unique<PendingSend>(std::move(o.bytes), o.rank, kTagMessage, comm_.get()));
    moved = true;
  }
  while (!pending_.empty() && pending_.front()->done()) {
    pending_.pop_front();
    moved = true;
  }
  for (;;) {
    int flag = 0;
    MPI_Message handle = MPI_MESSAGE_NULL;
    MPI_Status status;
    check(MPI_Improbe(MPI_ANY_SOURCE, MPI_ANY_TAG, comm_.get(), &flag, &handle, &status), "MPI_Improbe");
    if (!flag) break;
    int count = 0;
    check(MPI_Get_count(&status, MPI_BYTE, &count), "MPI_Get_count");
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(count));
    check(MPI_Mrecv(bytes.data(), count, MPI_BYTE, &handle, MPI_STATUS_IGNORE), "MPI_Mrecv");
    moved = true;
    if (status.MPI_TAG == kTagFailure) {
      {
        std::lock_guard lock(mutex_);
        if (failure_.empty())
          failure_ = "rank " + std::to_string(status.MPI_SOURCE) + " failed: " + std::string(bytes.begin(), bytes.end());
      }
      local_->close();
      continue;
    }
    in_messages_.fetch_add(1, std::memory_order_relaxed);
    in_bytes_.fetch_add(bytes.size(), std::memory_order_relaxed);
    Message m = decode_message(bytes);
    if (m.to < 0 || static_cast<std::size_t>(m.to) >= rank_of_world_.size() ||
        rank_of_world_[static_cast<std::size_t>(m.to)] != rank_)
      throw std::logic_error("MpiTransport: rank " + std::to_string(rank_) + " received " + describe(m) +
                             " from rank " + std::to_string(status.MPI_SOURCE) + ", for a world it does not step");
    const WorldId to = m.to;
    local_->send(to, std::move(m));
  }
  return moved;
}

bool MpiTransport::idle() {
  std::lock_guard lock(mutex_);
  return outbox_.empty() && pending_.empty();
}

void MpiTransport::send_failure(const std::string& what) {
  for (int r = 0; r < comm_.size(); ++r)
    if (r != rank_)
      pending_.push_back(std::make_unique<PendingSend>(std::vector<std::uint8_t>(what.begin(), what.end()), r,
                                                       kTagFailure, comm_.get()));
}

void MpiTransport::flush(double seconds) {
  const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  while (!pending_.empty() && std::chrono::steady_clock::now() < end) {
    while (!pending_.empty() && pending_.front()->done()) pending_.pop_front();
    std::this_thread::yield();
  }
}

void MpiTransport::wait_for_outbox(int micros) {
  std::unique_lock lock(mutex_);
  queued_.wait_for(lock, std::chrono::microseconds(micros), [&] { return !outbox_.empty(); });
}

std::string MpiTransport::remote_failure() const {
  std::lock_guard lock(mutex_);
  return failure_;
}

void MpiTransport::add_traffic(RankTraffic& t) const {
  t.messages_out += out_messages_.load();
  t.bytes_out += out_bytes_.load();
  t.messages_in += in_messages_.load();
  t.bytes_in += in_bytes_.load();
}

}  // namespace soda::mpi
