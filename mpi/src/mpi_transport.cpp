#include "mpi_transport.h"

#include <chrono>
#include <climits>
#include <initializer_list>
#include <stdexcept>
#include <thread>

#include "soda/runtime/message_codec.h"

namespace soda::mpi {
namespace {

// The fields of requests and entries: little-endian 64-bit words.
void put_word(std::vector<std::uint8_t>& out, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

std::uint64_t take_word(const std::vector<std::uint8_t>& in, std::size_t& at) {
  if (at + 8 > in.size()) throw std::runtime_error("MpiTransport: a truncated rollback request or entry");
  std::uint64_t v = 0;
  for (int i = 0; i < 8; ++i) v |= static_cast<std::uint64_t>(in[at + static_cast<std::size_t>(i)]) << (8 * i);
  at += 8;
  return v;
}

std::vector<std::uint8_t> words(std::initializer_list<std::uint64_t> values) {
  std::vector<std::uint8_t> out;
  for (std::uint64_t v : values) put_word(out, v);
  return out;
}

}  // namespace

namespace {
int comm_size(MPI_Comm comm) {
  int n = 0;
  check(MPI_Comm_size(comm, &n), "MPI_Comm_size");
  return n;
}
int comm_rank(MPI_Comm comm) {
  int r = 0;
  check(MPI_Comm_rank(comm, &r), "MPI_Comm_rank");
  return r;
}
}  // namespace

MpiTransport::MpiTransport(MPI_Comm comm, std::vector<int> rank_of_world, std::unique_ptr<Transport> local,
                           std::uint64_t run)
    : comm_(comm),
      size_(comm_size(comm)),
      tag_base_(kTagBase + kTagsPerRun * static_cast<int>(run % kRuns)),
      rank_(comm_rank(comm)),
      rank_of_world_(std::move(rank_of_world)),
      local_(std::move(local)),
      rounds_(comm, size_) {}

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
  Outgoing out{rank, kMessage, encode_message(message), message.step, std::nullopt};
  if (out.bytes.size() > static_cast<std::size_t>(INT_MAX))
    throw std::length_error("MpiTransport: a message of " + std::to_string(out.bytes.size()) +
                            " bytes, more than one MPI send carries (" + describe(message) + ")");
  if (const Control* c = std::get_if<Control>(&message.payload); c && c->type == Control::Type::Notice)
    out.timestamp = c->pinned, out.pinned = c->pinned;  // the sender pinned it (speculation.cpp)
  out_messages_.fetch_add(1, std::memory_order_relaxed);
  out_bytes_.fetch_add(out.bytes.size(), std::memory_order_relaxed);
  queue(std::move(out));
}

void MpiTransport::queue(Outgoing out) {
  {
    std::lock_guard lock(mutex_);
    outbox_.push_back(std::move(out));
  }
  queued_.notify_one();
}

void MpiTransport::close() {
  local_->close();
  if (board_) board_->close();
}

void MpiTransport::share_rollbacks(SharedMemoryHorizon& horizon, RollbackBoard& board) {
  horizon_ = &horizon;
  board_ = &board;
  RollbackBoard::Ranks ranks;
  for (int r : rank_of_world_) ranks.local.push_back(r == rank_);
  ranks.request = [this](std::int64_t step, std::int64_t pinned, std::uint64_t ticket) {
    if (rank_ == 0) {
      sequence(step, pinned, 0, ticket);
      horizon_->unpin(pinned);  // post()'s pin: sequence() pinned it for every world and rank
      return;
    }
    queue(Outgoing{0, kRequest,
                   words({static_cast<std::uint64_t>(step), static_cast<std::uint64_t>(pinned), ticket}), pinned,
                   pinned});
  };
  ranks.stop = [] { throw TransportClosed("MpiTransport: the run is stopping (another world or rank failed)"); };
  board.distribute(std::move(ranks));
}

void MpiTransport::sequence(std::int64_t step, std::int64_t pinned, int origin, std::uint64_t ticket) {
  std::lock_guard lock(sequence_mutex_);
  const std::uint32_t epoch = board_->append(step, pinned, ticket, origin == rank_);
  for (int r = 0; r < size_; ++r) {
    if (r == rank_) continue;
    horizon_->pin(pinned);  // until posted (invariant 4)
    queue(Outgoing{r, kEntry,
                   words({epoch, static_cast<std::uint64_t>(step), static_cast<std::uint64_t>(pinned),
                          static_cast<std::uint64_t>(origin), ticket}),
                   pinned, pinned});
  }
}

bool MpiTransport::poll_horizon(bool failed) {
  if (!horizon_) return false;
  const std::optional<std::int64_t> gvt = rounds_.poll([this] { return horizon_->local_minimum(); }, failed);
  if (!gvt) return false;
  horizon_->set_global(*gvt);
  return true;
}

bool MpiTransport::progress() {
  bool moved = false;
  std::deque<Outgoing> batch;
  {
    std::lock_guard lock(mutex_);
    batch.swap(outbox_);
  }
  for (Outgoing& o : batch) {
    const int colour = rounds_.colour();
    pending_.push_back(
        std::make_unique<PendingSend>(std::move(o.bytes), o.rank, tag_base_ + 2 * o.kind + colour, comm_));
    rounds_.sent(o.rank, o.timestamp);
    if (o.pinned) horizon_->unpin(*o.pinned);  // counted by the cut from now on (invariant 4)
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
    check(MPI_Improbe(MPI_ANY_SOURCE, MPI_ANY_TAG, comm_, &flag, &handle, &status), "MPI_Improbe");
    if (!flag) break;
    int count = 0;
    check(MPI_Get_count(&status, MPI_BYTE, &count), "MPI_Get_count");
    std::vector<std::uint8_t> bytes(static_cast<std::size_t>(count));
    check(MPI_Mrecv(bytes.data(), count, MPI_BYTE, &handle, MPI_STATUS_IGNORE), "MPI_Mrecv");
    moved = true;
    const int tag = status.MPI_TAG - tag_base_;
    if (tag < 0 || tag >= kTagsPerRun) continue;  // an earlier run's, left on the wire
    if (tag == kTagFailure) {
      {
        std::lock_guard lock(mutex_);
        if (failure_.empty())
          failure_ = "rank " + std::to_string(status.MPI_SOURCE) + " failed: " + std::string(bytes.begin(), bytes.end());
      }
      close();
      continue;
    }
    rounds_.received(tag % 2);
    arrived(tag / 2, status.MPI_SOURCE, std::move(bytes));
  }
  return moved;
}

void MpiTransport::arrived(int kind, int source, std::vector<std::uint8_t> bytes) {
  std::size_t at = 0;
  if (kind == kRequest) {
    if (rank_ != 0 || !board_) throw std::logic_error("MpiTransport: a rollback request outside rank 0's board");
    const auto step = static_cast<std::int64_t>(take_word(bytes, at));
    const auto pinned = static_cast<std::int64_t>(take_word(bytes, at));
    sequence(step, pinned, source, take_word(bytes, at));
    return;
  }
  if (kind == kEntry) {
    if (!board_) throw std::logic_error("MpiTransport: a rollback of every world without speculation");
    const std::uint64_t epoch = take_word(bytes, at);
    const auto step = static_cast<std::int64_t>(take_word(bytes, at));
    const auto pinned = static_cast<std::int64_t>(take_word(bytes, at));
    const auto origin = static_cast<int>(take_word(bytes, at));
    const std::uint64_t ticket = take_word(bytes, at);
    if (board_->append(step, pinned, ticket, origin == rank_) != epoch)
      throw std::logic_error("MpiTransport: rollbacks of every world out of rank 0's order");
    return;
  }
  in_messages_.fetch_add(1, std::memory_order_relaxed);
  in_bytes_.fetch_add(bytes.size(), std::memory_order_relaxed);
  Message m = decode_message(bytes);
  if (m.to < 0 || static_cast<std::size_t>(m.to) >= rank_of_world_.size() ||
      rank_of_world_[static_cast<std::size_t>(m.to)] != rank_)
    throw std::logic_error("MpiTransport: rank " + std::to_string(rank_) + " received " + describe(m) +
                           " from rank " + std::to_string(source) + ", for a world it does not step");
  if (const Control* c = std::get_if<Control>(&m.payload); c && c->type == Control::Type::Notice) {
    // The receiver unpins it once taken in (speculation.cpp), as on one machine.
    if (!horizon_) throw std::logic_error("MpiTransport: a rollback notice without speculation: " + describe(m));
    horizon_->pin(c->pinned);  // its pin moved with it (CommitHorizon::pin)
  }
  const WorldId to = m.to;
  local_->send(to, std::move(m));
}

bool MpiTransport::idle() {
  std::lock_guard lock(mutex_);
  return outbox_.empty() && pending_.empty();
}

void MpiTransport::send_failure(const std::string& what) {
  for (int r = 0; r < size_; ++r)
    if (r != rank_)
      pending_.push_back(std::make_unique<PendingSend>(std::vector<std::uint8_t>(what.begin(), what.end()), r,
                                                       tag_base_ + kTagFailure, comm_));
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
  t.gvt_rounds += rounds_.rounds();  // the MPI thread's: the caller is the thread that pumps
}

}  // namespace soda::mpi
