// make_balance_policy: options checked, then the named policy.
#include <string>

#include "churn_policy.h"
#include "diffusive_policy.h"
#include "rcb_policy.h"
#include "soda/loadbalance/policy.h"

namespace soda {
namespace {

/// Never moves a cell: the fixed territories of a run without balancing.
class NoBalance final : public BalancePolicy {
 public:
  const char* name() const override { return "none"; }
  std::vector<CellMove> decide(const LoadView&) override { return {}; }
};

void check_options(const BalanceOptions& o) {
  if (o.period < 1) throw BalanceError("balance period must be >= 1 step, got " + std::to_string(o.period));
  if (!(o.smoothing > 0 && o.smoothing <= 1))
    throw BalanceError("balance smoothing must be in (0, 1], got " + std::to_string(o.smoothing));
  if (!(o.underload > 0 && o.underload < 1 && o.overload > 1))
    throw BalanceError("balance thresholds need 0 < underload < 1 < overload, got underload " +
                       std::to_string(o.underload) + ", overload " + std::to_string(o.overload));
  if (o.max_cells_per_move < 1)
    throw BalanceError("balance max_cells_per_move must be >= 1, got " + std::to_string(o.max_cells_per_move));
}

}  // namespace

std::unique_ptr<BalancePolicy> make_balance_policy(const BalanceOptions& options) {
  check_options(options);
  if (options.policy == "none") return std::make_unique<NoBalance>();
  if (options.policy == "churn") return std::make_unique<detail::ChurnPolicy>(options);
  if (options.policy == "diffusive") return std::make_unique<detail::DiffusivePolicy>(options);
  if (options.policy == "rcb") return std::make_unique<detail::RcbPolicy>(options);
  throw BalanceError("unknown balance policy '" + options.policy + "' (none, diffusive, rcb, churn)");
}

}  // namespace soda
