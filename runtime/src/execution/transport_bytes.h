// Internal: bytes the calling thread has encoded in Transport::send so far
// (serialising transports only; defined in transport.cpp). A world's step
// sends from the world's thread, so the difference around a send is that
// send's size: per-stage byte counts without a change to Transport.
#pragma once

#include <cstdint>

namespace soda {

std::uint64_t thread_bytes_sent();

}  // namespace soda
