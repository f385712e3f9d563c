// Internal: the watchdog's checks on Bullet objects, shared by the canonical
// and the territory worlds (watchdog.h).
#pragma once

#include <vector>

#include <btBulletDynamicsCommon.h>

#include "soda/worlds/watchdog.h"

namespace soda {

/// Appends what is wrong with one body's end-of-step state.
void watchdog_scan_body(const btRigidBody& body, BodyId id, const WatchdogLimits& limits,
                        std::vector<WatchdogFinding>& out);
/// Appends the deepest point of a manifold if it is deeper than allowed.
void watchdog_scan_manifold(const btPersistentManifold& manifold, const WatchdogLimits& limits,
                            std::vector<WatchdogFinding>& out);
/// Every manifold of a dispatcher, as above.
void watchdog_scan_manifolds(btDispatcher& dispatcher, const WatchdogLimits& limits, std::vector<WatchdogFinding>& out);
/// Sorts findings by (body, kind, other) and keeps the first 16.
void watchdog_sort(std::vector<WatchdogFinding>& findings);

}  // namespace soda
