#include "soda/loadbalance/cost_model.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace soda {
namespace {

constexpr int kTerms = 5;  // overhead, per_body, per_awake, per_pair, per_triangle
// Ridge strength relative to each term's own sum of squares: small enough
// that data which sees a term decides it (a 0.01 % pull: 1e-3 moved
// correlated terms by 3 % towards a prior 4x off), large enough that a
// term the data cannot separate from another stays near the prior.
constexpr double kRidge = 1e-4;

using Row = std::array<double, kTerms>;

Row features(const CostSample& s) { return {1.0, s.bodies, s.awake_bodies, s.contact_pairs, s.body_triangles}; }
Row as_row(const CostCoefficients& c) { return {c.overhead, c.per_body, c.per_awake, c.per_pair, c.per_triangle}; }
CostCoefficients as_coefficients(const Row& r) { return {r[0], r[1], r[2], r[3], r[4]}; }

// Solves a x = b for the terms marked free (others fixed at 0) by Gaussian
// elimination with partial pivoting; returns false if singular.
bool solve(std::array<Row, kTerms> a, Row b, const std::array<bool, kTerms>& free, Row& x) {
  std::array<int, kTerms> idx{};
  int n = 0;
  for (int i = 0; i < kTerms; ++i)
    if (free[i]) idx[n++] = i;
  std::array<Row, kTerms> m{};
  Row r{};
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) m[i][j] = a[idx[i]][idx[j]];
    r[i] = b[idx[i]];
  }
  for (int col = 0; col < n; ++col) {
    int pivot = col;
    for (int i = col + 1; i < n; ++i)
      if (std::abs(m[i][col]) > std::abs(m[pivot][col])) pivot = i;
    if (!(std::abs(m[pivot][col]) > 0)) return false;
    std::swap(m[pivot], m[col]);
    std::swap(r[pivot], r[col]);
    for (int i = col + 1; i < n; ++i) {
      const double f = m[i][col] / m[col][col];
      for (int j = col; j < n; ++j) m[i][j] -= f * m[col][j];
      r[i] -= f * r[col];
    }
  }
  Row y{};
  for (int i = n - 1; i >= 0; --i) {
    double s = r[i];
    for (int j = i + 1; j < n; ++j) s -= m[i][j] * y[j];
    y[i] = s / m[i][i];
  }
  x = Row{};
  for (int i = 0; i < n; ++i) x[idx[i]] = y[i];
  return true;
}

// Ridge pull towards the prior c0, relative to each term's own scale.
void add_ridge(std::array<Row, kTerms>& a, Row& b, const Row& c0) {
  for (int i = 0; i < kTerms; ++i) {
    const double lambda = kRidge * std::max(a[i][i], 1.0);
    a[i][i] += lambda;
    b[i] += lambda * c0[i];
  }
}

// Non-negativity by elimination: a term that comes out negative is fixed at
// 0 and the rest solved again (at most kTerms rounds).
bool solve_non_negative(const std::array<Row, kTerms>& a, const Row& b, Row& x) {
  std::array<bool, kTerms> free{};
  free.fill(true);
  for (int round = 0; round < kTerms; ++round) {
    if (!solve(a, b, free, x)) return false;
    int worst = -1;
    for (int i = 0; i < kTerms; ++i)
      if (free[i] && x[i] < 0 && (worst < 0 || x[i] < x[worst])) worst = i;
    if (worst < 0) break;
    free[worst] = false;
    x[worst] = 0;
  }
  return true;
}

}  // namespace

CostSample cost_sample(const WorldLoad& load) {
  return {static_cast<double>(load.bodies), static_cast<double>(load.awake_bodies),
          static_cast<double>(load.contact_pairs), load.busy, static_cast<double>(load.body_triangles)};
}

CostModel CostModel::fit(std::span<const CostSample> samples, const CostCoefficients& prior) {
  if (static_cast<int>(samples.size()) < kMinFitSamples) return CostModel(prior, false);
  // Normal equations (X^T X + L) c = X^T y + L c0, L diagonal.
  std::array<Row, kTerms> a{};
  Row b{};
  for (const CostSample& s : samples) {
    const Row f = features(s);
    for (int i = 0; i < kTerms; ++i) {
      for (int j = 0; j < kTerms; ++j) a[i][j] += f[i] * f[j];
      b[i] += f[i] * s.busy;
    }
  }
  const Row c0 = as_row(prior);
  add_ridge(a, b, c0);
  Row x{};
  if (!solve_non_negative(a, b, x)) return CostModel(prior, false);
  for (double& v : x) v = std::max(v, 0.0);
  return CostModel(as_coefficients(x), true);
}

double CostModel::predict(double bodies, double awake_bodies, double contact_pairs, double body_triangles) const {
  const CostCoefficients& c = coefficients_;
  return c.overhead + c.per_body * bodies + c.per_awake * awake_bodies + c.per_pair * contact_pairs +
         c.per_triangle * body_triangles;
}

double CostModel::predict(const WorldLoad& load) const {
  return predict(static_cast<double>(load.bodies), static_cast<double>(load.awake_bodies),
                 static_cast<double>(load.contact_pairs), static_cast<double>(load.body_triangles));
}

double CostModel::cell_cost(const CellLoad& cell) const {
  return predict(cell.bodies, cell.awake_bodies, cell.contact_pairs,
                 static_cast<double>(cell.awake_bodies) * static_cast<double>(cell.triangles)) -
         coefficients_.overhead;
}

CostFitQuality CostModel::quality(std::span<const CostSample> samples) const {
  CostFitQuality q;
  double sum = 0, abs_sum = 0, busy_sum = 0;
  for (const CostSample& s : samples) {
    if (!(s.busy > 0)) continue;
    const double abs_error = std::abs(predict(s.bodies, s.awake_bodies, s.contact_pairs, s.body_triangles) - s.busy);
    const double e = abs_error / s.busy;
    sum += e;
    abs_sum += abs_error;
    busy_sum += s.busy;
    q.max_relative_error = std::max(q.max_relative_error, e);
    ++q.samples;
  }
  if (q.samples > 0) {
    q.mean_relative_error = sum / q.samples;
    q.weighted_relative_error = abs_sum / busy_sum;
  }
  return q;
}

}  // namespace soda
