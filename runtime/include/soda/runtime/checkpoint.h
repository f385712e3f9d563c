// runtime/ — checkpoints on disk: a SimulationSnapshot (simulation.h) as a
// versioned binary file, written by Simulation::save and read back by
// Simulation::resume (or read_checkpoint and the snapshot constructor), from
// which a Simulation goes on bit for bit as the run it was saved from, with
// any territories, partition, threads or speculation. Format and contract:
// docs/checkpoints.md.
//
// A file is read whole and checked before anything of it is used: its
// magic, its version, the precision it was written in (btScalar bytes: a
// checkpoint of the float build is not one of the double build), its length
// and a 64-bit checksum (FNV-1a) of every byte; then every field, as the
// snapshot codec checks it. Anything else — a truncated file, a flipped byte,
// a file of another version or precision — is refused with a CheckpointError
// naming the file and what is wrong; reading never goes out of bounds and
// allocates no more than the file's size.
//
// Thread safety: pure functions of their arguments; keeping two writers of
// one path apart is the caller's business.
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace soda {

struct SimulationSnapshot;  // simulation.h

/// A file that is not a checkpoint this build can read: unreadable,
/// truncated, damaged (checksum), another version, another precision, or
/// fields that do not hold. Also thrown when a checkpoint cannot be written.
/// what() names the file (or the `source` given) and the reason.
class CheckpointError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The checkpoint format version this build writes. It reads this one and
/// every one from kOldestCheckpointVersion on (docs/checkpoints.md, "Versions").
inline constexpr std::uint32_t kCheckpointVersion = 12;
/// Version 1: body records without a collision filter (they read back with
/// the default one); version 2: without compound children; version 3:
/// without user data (it reads back as 0), and inputs without the value and
/// user data fields and the kinds after apply_impulse; version 4: without
/// triangle mesh and heightfield data (no such statics); version 5: without
/// the sensor flag (bodies read back as not sensors); version 6: without
/// kinematic bodies, and inputs without an orientation and kinds 9 and 10;
/// version 7: without joints; version 8: inputs without a joint id and
/// kind 11 (remove_joint); version 9: without kinds 12 (add_joint) and 13
/// (set_joint_motor), and inputs without a motor; version 10: without kind
/// 14 (set_collision_filter); version 11: without a kinematic body's
/// collision filter inputs.
inline constexpr std::uint32_t kOldestCheckpointVersion = 1;

/// What a checkpoint's fixed header says (docs/checkpoints.md, "Header").
struct CheckpointHeader {
  std::uint32_t version = kCheckpointVersion;
  std::uint32_t scalar_bytes = 0;  // sizeof(btScalar) of the build that wrote it: 4 float, 8 double
  std::int64_t step = 0;           // the scene step it was saved at
  std::uint32_t bodies = 0;        // statics included
  std::uint32_t manifolds = 0;
  std::uint32_t inputs = 0;        // queued for steps at or after `step`
  std::uint32_t retired_ids = 0;
};

/// The checkpoint bytes of `snapshot`.
std::vector<std::uint8_t> encode_checkpoint(const SimulationSnapshot& snapshot);
/// The same in an older format `version` (kOldestCheckpointVersion ..
/// kCheckpointVersion), for a tool that must hand a file to an older build.
/// Throws CheckpointError, naming the body or the input, if the snapshot
/// holds what that version cannot say (before 12: a kinematic body's
/// collision filter inputs; before 10: an add_joint or
/// set_joint_motor input;
/// before 9: a remove_joint input;
/// before 8: a joint; before 7: a
/// kinematic body; before 6: a sensor; before 5: a triangle mesh or heightfield; before 4: a body's user data other
/// than 0, an input of a kind after apply_impulse; before 3: a compound
/// shape; before 2: a collision filter other than the default).
std::vector<std::uint8_t> encode_checkpoint(const SimulationSnapshot& snapshot, std::uint32_t version);

/// Inverse of encode_checkpoint, bit for bit. Throws CheckpointError
/// ("checkpoint <source>: <reason>") for anything but a whole, intact
/// checkpoint of a version this build reads and of this build's precision.
SimulationSnapshot decode_checkpoint(const std::vector<std::uint8_t>& bytes, const std::string& source = "bytes");

/// The header of checkpoint bytes, checked as decode_checkpoint checks it
/// (magic, version, precision, length, checksum) without decoding the body.
CheckpointHeader checkpoint_header(const std::vector<std::uint8_t>& bytes, const std::string& source = "bytes");

/// Writes encode_checkpoint(snapshot) to `path`: to `path` + ".tmp" first,
/// then renamed over `path`, so that a reader never sees half a file.
/// Returns the bytes written. Throws CheckpointError naming the path if it
/// cannot be written.
std::uint64_t write_checkpoint(const SimulationSnapshot& snapshot, const std::string& path);

/// Reads the checkpoint at `path` (decode_checkpoint). Throws
/// CheckpointError naming the file if it cannot be read or is not a
/// checkpoint this build reads.
SimulationSnapshot read_checkpoint(const std::string& path);

}  // namespace soda
