// worlds/ — the partitioned step's error type and its process-wide switch
// (border culling); territory_world.h brings them.
#pragma once

#include <stdexcept>

namespace soda {

/// A scene or a trajectory outside what the partitioned step supports (a halo
/// reaching a world that is not a neighbour, a body moving to a non-neighbour
/// — beyond the map's reach, see reach.h: the message names the body, its
/// speed and the reach speed that would cover it —) or a broken protocol
/// invariant (two owners for one body). The message names the body, the
/// step and the worlds.
class PartitionError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Border culling (docs/skip.md): predict() looks up the cells of an owned
/// body's halo only when the halo leaves the block of 27 owned cells it was
/// last found in. On by default; results are the same either way (tests
/// compare). Process-wide, for tests and benches: set it while no territory
/// world steps (a relaxed atomic read once per predict()).
void set_border_culling(bool on);
bool border_culling();

}  // namespace soda
