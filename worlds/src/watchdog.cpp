// The watchdog's checks and messages (watchdog.h).
#include <algorithm>
#include <cmath>
#include <sstream>
#include <tuple>

#include "soda/worlds/watchdog.h"
#include "canonical_world_parts.h"
#include "watchdog_scan.h"

namespace soda {
namespace {

bool finite(const btVector3& v) { return std::isfinite(v.x()) && std::isfinite(v.y()) && std::isfinite(v.z()); }

}  // namespace

const char* watchdog_response_name(WatchdogResponse response) {
  switch (response) {
    case WatchdogResponse::Off: return "off";
    case WatchdogResponse::Stop: return "stop";
    case WatchdogResponse::Heal: return "heal";
  }
  return "unknown";
}

WatchdogResponse parse_watchdog_response(const std::string& text) {
  if (text == "off") return WatchdogResponse::Off;
  if (text == "stop") return WatchdogResponse::Stop;
  if (text == "heal") return WatchdogResponse::Heal;
  throw std::invalid_argument("unknown watchdog response '" + text + "' (expected off, stop or heal)");
}

// The cheap path first (callgrind: this runs for every body and step): a
// sleeping body has not moved since it fell asleep, when it was checked; the
// sum of every component is finite unless one of them is not (or the values
// are so large that the sum overflows: then the exact check decides); speeds
// compare squared.
void watchdog_scan_body(const btRigidBody& body, BodyId id, const WatchdogLimits& limits,
                        std::vector<WatchdogFinding>& out) {
  if (body.getActivationState() == ISLAND_SLEEPING) return;
  const btTransform& t = body.getWorldTransform();
  const btVector3& v = body.getLinearVelocity();
  const btVector3& w = body.getAngularVelocity();
  const btMatrix3x3& b = t.getBasis();
  const btVector3 sum = t.getOrigin() + b[0] + b[1] + b[2] + v + w;
  if (!std::isfinite(double(sum.x()) + double(sum.y()) + double(sum.z()))) {
    if (!finite(t.getOrigin()) || !finite(b[0]) || !finite(b[1]) || !finite(b[2]) || !finite(v) || !finite(w)) {
      out.push_back({WatchdogFinding::Kind::NonFinite, id, 0, std::nan("")});
      return;
    }
  }
  const double speed2 = double(v.length2());
  if (limits.max_speed < 0 || speed2 > limits.max_speed * limits.max_speed)
    out.push_back({WatchdogFinding::Kind::Speed, id, 0, std::sqrt(speed2)});
  const double spin2 = double(w.length2());
  if (limits.max_angular_speed < 0 || spin2 > limits.max_angular_speed * limits.max_angular_speed)
    out.push_back({WatchdogFinding::Kind::AngularSpeed, id, 0, std::sqrt(spin2)});
}

void watchdog_scan_manifold(const btPersistentManifold& m, const WatchdogLimits& limits,
                            std::vector<WatchdogFinding>& out) {
  double deepest = 0;
  for (int i = 0; i < m.getNumContacts(); ++i) deepest = std::max(deepest, -double(m.getContactPoint(i).getDistance()));
  if (deepest > limits.max_penetration)
    out.push_back({WatchdogFinding::Kind::Penetration, static_cast<BodyId>(m.getBody0()->getUserIndex()),
                   static_cast<BodyId>(m.getBody1()->getUserIndex()), deepest});
}

void watchdog_scan_manifolds(btDispatcher& dispatcher, const WatchdogLimits& limits,
                             std::vector<WatchdogFinding>& out) {
  for (int i = 0; i < dispatcher.getNumManifolds(); ++i)
    watchdog_scan_manifold(*dispatcher.getManifoldByIndexInternal(i), limits, out);
}

void watchdog_sort(std::vector<WatchdogFinding>& findings) {
  std::sort(findings.begin(), findings.end(), [](const WatchdogFinding& a, const WatchdogFinding& b) {
    return std::make_tuple(a.body, static_cast<int>(a.kind), a.other) <
           std::make_tuple(b.body, static_cast<int>(b.kind), b.other);
  });
  if (findings.size() > 16) findings.resize(16);
}

std::string describe(const WatchdogFinding& f, const WatchdogLimits& limits) {
  std::ostringstream s;
  s << "body " << f.body << ": ";
  switch (f.kind) {
    case WatchdogFinding::Kind::NonFinite: s << "non-finite state (NaN or Inf in its transform or velocities)"; break;
    case WatchdogFinding::Kind::Speed: s << "speed " << f.value << " m/s > " << limits.max_speed; break;
    case WatchdogFinding::Kind::AngularSpeed:
      s << "angular speed " << f.value << " rad/s > " << limits.max_angular_speed;
      break;
    case WatchdogFinding::Kind::Penetration:
      s << "penetrates body " << f.other << " by " << f.value << " m > " << limits.max_penetration;
      break;
  }
  return s.str();
}

namespace {

std::string message_of(std::int64_t step, WorldId world, const std::vector<WatchdogFinding>& findings,
                       const WatchdogLimits& limits, const std::string& context) {
  std::ostringstream s;
  s << "watchdog: step " << step;
  if (world != kNoWorld) s << ", world " << world;
  s << ": ";
  for (std::size_t i = 0; i < findings.size(); ++i) s << (i ? "; " : "") << describe(findings[i], limits);
  if (!context.empty()) s << " (" << context << ")";
  return s.str();
}

}  // namespace

WatchdogError::WatchdogError(std::int64_t step, WorldId world, std::vector<WatchdogFinding> findings,
                             const WatchdogLimits& limits, const std::string& context)
    : std::runtime_error(message_of(step, world, findings, limits, context)),
      step_(step),
      world_(world),
      findings_(std::move(findings)) {}

std::vector<WatchdogFinding> CanonicalWorld::watchdog_findings(const WatchdogLimits& limits) const {
  std::vector<WatchdogFinding> out;
  // The dynamic bodies in Bullet's world: parked ones are not scanned, their
  // state is what it was at their last scan in the world (parking.h).
  for (const btRigidBody* b : parts_->world.dynamic_bodies())
    watchdog_scan_body(*b, static_cast<BodyId>(b->getUserIndex()), limits, out);
  watchdog_scan_manifolds(parts_->dispatcher, limits, out);
  watchdog_sort(out);
  return out;
}

}  // namespace soda
