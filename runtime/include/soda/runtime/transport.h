// runtime/ — how messages travel between worlds. One small interface, two
// implementations in one process: values through in-memory queues, or every
// message turned into bytes and back (what a transport between processes will
// do; the tests run on it).
//
// Thread safety: every member is safe to call from any thread. Messages from
// one sender to one receiver arrive in the order they were sent.
#pragma once

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

}  // namespace soda
