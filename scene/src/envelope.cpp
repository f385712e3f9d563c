#include "soda/scene/envelope.h"

#include <cmath>
#include <limits>

namespace soda {
namespace {

template <class T>
PrecisionEnvelope envelope_of(Precision precision, double h) {
  using L = std::numeric_limits<T>;
  PrecisionEnvelope e;
  e.precision = precision;
  e.epsilon = static_cast<double>(L::epsilon());
  e.max_finite = static_cast<double>(L::max());
  e.step = h;
  e.min_step = e.epsilon * kUnitLength / kSlowestSpeed;
  e.max_position = kSlowestSpeed * h / e.epsilon;
  e.min_mass = std::sqrt(static_cast<double>(L::min()));
  e.max_mass = std::sqrt(e.max_finite);
  e.max_angular_speed = kMaxStepRotation / h;
  return e;
}

}  // namespace

const char* precision_name(Precision precision) { return precision == Precision::Float ? "float" : "double"; }

PrecisionEnvelope PrecisionEnvelope::of(Precision precision, double dt, int substeps) {
  const double h = dt / (substeps > 0 ? substeps : 1);
  return precision == Precision::Float ? envelope_of<float>(precision, h) : envelope_of<double>(precision, h);
}

}  // namespace soda
