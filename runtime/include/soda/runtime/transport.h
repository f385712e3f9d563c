// runtime/ — how messages travel between worlds. One small interface, two
// implementations in one process: values through in-memory queues, or every
// message turned into bytes and back (what a transport between processes will
// do; the tests run on it).
//
// Thread safety: every member is safe to call from any thread. Messages from
// one sender to one receiver arrive in the order they were sent.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>

#include "soda/runtime/messages.h"

namespace soda {

/// Thrown by Transport::receive once the transport is closed.
class TransportClosed : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class Transport {
 public:
  virtual ~Transport() = default;
  /// Queues `message` for world `to` (message.to must equal `to`).
  virtual void send(WorldId to, Message message) = 0;
  /// The next message for `world`, if one is queued; never blocks.
  virtual std::optional<Message> try_receive(WorldId world) = 0;
  /// The next message for `world`; blocks on a condition variable until one
  /// is queued. Throws TransportClosed after close().
  virtual Message receive(WorldId world) = 0;
  /// For task scheduling: if nothing is queued for `world`, marks it parked
  /// and returns true; the next send to it then calls the wake hook (once).
  /// Returns false (not parked) if a message is already queued; true, without
  /// any wake to come, once the transport is closed.
  virtual bool park(WorldId world) = 0;
  /// Called, outside any lock, with the id of a parked world a message was
  /// just queued for. Set before any message is sent.
  virtual void set_wake_hook(std::function<void(WorldId)> hook) = 0;
  /// Wakes every blocked receive (they throw TransportClosed); later messages
  /// are dropped.
  virtual void close() = 0;
  /// Messages and bytes sent so far (bytes: 0 for in-memory values).
  virtual std::uint64_t messages_sent() const = 0;
  virtual std::uint64_t bytes_sent() const = 0;
};

/// Messages as values through per-world queues.
std::unique_ptr<Transport> make_in_memory_transport(int world_count);
/// Every message encoded to bytes on send and decoded on receive
/// (message_codec.h): a malformed message throws MessageFormatError in the
/// receiving world.
std::unique_ptr<Transport> make_serialising_transport(int world_count);

/// Fuzzing (tests): a seeded source of random pauses, safe to share between
/// threads (the sequence drawn depends on the threads' timing; the seed only
/// makes runs differ from each other).
class FuzzRandom {
 public:
  explicit FuzzRandom(std::uint64_t seed) : state_(seed * 0x9E3779B97F4A7C15ull + 1) {}
  std::uint64_t next() {  // splitmix64
    std::uint64_t z = state_.fetch_add(0x9E3779B97F4A7C15ull, std::memory_order_relaxed) + 0x9E3779B97F4A7C15ull;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }

 private:
  std::atomic<std::uint64_t> state_;
};
/// One call in four: sleeps up to 300 µs (or yields).
void fuzz_pause(FuzzRandom& random);
/// `inner`, with every send delayed by fuzz_pause in the sending thread.
std::unique_ptr<Transport> make_fuzzing_transport(std::unique_ptr<Transport> inner, std::uint64_t seed);

}  // namespace soda
