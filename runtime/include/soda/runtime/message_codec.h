// runtime/ — messages to bytes and back, for the serialising transport and,
// later, a transport between processes.
//
// Layout: "SODAMSG1", u32 version, u32 sizeof(btScalar), u8 kind, i32 from,
// i32 to, i64 step, then the payload (counts as u32, bodies and manifolds as
// in worlds/value_codec.h). Little-endian host order.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "soda/runtime/messages.h"

namespace soda {

/// Thrown by decode_message for bytes that are not a valid message of this
/// build's precision; the message names the reason and the byte offset.
class MessageFormatError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bit-exact encoding: decode_message(encode_message(m)) == m, field for field.
std::vector<std::uint8_t> encode_message(const Message& message);

/// 64-bit FNV-1a of the message's encoding with the epoch left out: equal
/// for two messages whose encodings differ at most in the epoch (a message
/// re-sent unchanged after a rollback). Encodes into a per-thread buffer:
/// no copy of the payload, no allocation once the buffer has grown.
std::uint64_t message_digest(const Message& message);

/// Inverse of encode_message. Never undefined behaviour on bad input: throws
/// MessageFormatError (truncation, bad magic/version/precision/kind, counts
/// larger than the data, ids out of range, unsorted lists, trailing bytes).
Message decode_message(const std::vector<std::uint8_t>& bytes);

}  // namespace soda
