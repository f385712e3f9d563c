// Equal-size k-means (kmeans.h).
#include "soda/grid/kmeans.h"

#include <algorithm>
#include <functional>
#include <numeric>
#include <random>

#include "soda/grid/cell.h"

namespace soda {
namespace {

double dist2(const Vec3& a, const Vec3& b) {
  const double dx = a.x() - b.x();
  const double dy = a.y() - b.y();
  const double dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

// Uniform in [0, 1) from the raw engine output: std distributions are not
// specified bit for bit, the engine is.
double unit(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }

std::size_t pick_index(std::mt19937_64& rng, std::size_t n) {
  return static_cast<std::size_t>(rng() % n);
}

// k-means++: first centre uniform, then each next with probability ~ D^2.
std::vector<Vec3> seed_centroids(std::span<const Vec3> points, int k, std::mt19937_64& rng) {
  const std::size_t n = points.size();
  std::vector<Vec3> centroids;
  centroids.push_back(points[pick_index(rng, n)]);
  std::vector<double> d2(n);
  for (std::size_t i = 0; i < n; ++i) d2[i] = dist2(points[i], centroids[0]);
  while (static_cast<int>(centroids.size()) < k) {
    double total = 0.0;
    for (double d : d2) total += d;
    std::size_t chosen = 0;
    if (total > 0.0) {
      const double r = unit(rng) * total;
      double acc = 0.0;
      chosen = n;
      std::size_t last_positive = 0;
      for (std::size_t i = 0; i < n; ++i) {
        if (d2[i] > 0.0) last_positive = i;
        acc += d2[i];
        if (acc > r && d2[i] > 0.0) {
          chosen = i;
          break;
        }
      }
      if (chosen == n) chosen = last_positive;  // rounding at the very end
    } else {
      chosen = pick_index(rng, n);  // all points coincide with centres
    }
    centroids.push_back(points[chosen]);
    for (std::size_t i = 0; i < n; ++i) d2[i] = std::min(d2[i], dist2(points[i], centroids.back()));
  }
  return centroids;
}

// Size-constrained assignment: points with the strongest preference (nearest
// minus farthest centre most negative) choose first, each taking its nearest
// cluster with room. Sizes end at floor(n/k) or ceil(n/k).
// weights empty: equal size; else equal weight (kmeans.h).
std::vector<int> assign(std::span<const Vec3> points, std::span<const std::int64_t> weights,
                        const std::vector<Vec3>& centroids) {
  const std::size_t n = points.size();
  const std::size_t k = centroids.size();
  std::vector<double> key(n);
  for (std::size_t i = 0; i < n; ++i) {
    double best = dist2(points[i], centroids[0]);
    double worst = best;
    for (std::size_t c = 1; c < k; ++c) {
      const double d = dist2(points[i], centroids[c]);
      best = std::min(best, d);
      worst = std::max(worst, d);
    }
    key[i] = best - worst;
  }
  std::vector<std::size_t> order(n);
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return key[a] != key[b] ? key[a] < key[b] : a < b;
  });
  const std::size_t base = n / k;
  const std::size_t extra = n % k;  // clusters allowed to hold base + 1
  std::size_t big = 0;
  std::vector<std::size_t> size(k, 0);
  std::int64_t total = 0;
  for (std::int64_t w : weights) total += w;
  const std::int64_t cap = (total + static_cast<std::int64_t>(k) - 1) / static_cast<std::int64_t>(k);
  std::vector<std::int64_t> load(k, 0);
  std::vector<int> labels(n, -1);
  for (std::size_t i : order) {
    std::size_t chosen = k;
    double chosen_d = 0.0;
    for (std::size_t c = 0; c < k; ++c) {
      // Equal weight: some cluster is below cap while a point is left
      // (the loads sum to less than W <= k cap).
      const bool room = weights.empty() ? size[c] < base || (size[c] == base && big < extra) : load[c] < cap;
      if (!room) continue;
      const double d = dist2(points[i], centroids[c]);
      if (chosen == k || d < chosen_d) {
        chosen = c;
        chosen_d = d;
      }
    }
    if (size[chosen] == base) ++big;
    ++size[chosen];
    if (!weights.empty()) load[chosen] += weights[i];
    labels[i] = static_cast<int>(chosen);
  }
  return labels;
}

void update_centroids(std::span<const Vec3> points, const std::vector<int>& labels,
                      std::vector<Vec3>& centroids) {
  std::vector<Vec3> sum(centroids.size(), Vec3::Zero());
  std::vector<std::size_t> count(centroids.size(), 0);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto c = static_cast<std::size_t>(labels[i]);
    sum[c] += points[i];
    ++count[c];
  }
  for (std::size_t c = 0; c < centroids.size(); ++c)
    if (count[c] > 0) centroids[c] = sum[c] / static_cast<double>(count[c]);
}

}  // namespace

KMeansResult equal_size_kmeans(std::span<const Vec3> points, int k, std::uint64_t seed,
                               int max_iterations) {
  return equal_size_kmeans(points, std::span<const std::int64_t>{}, k, seed, max_iterations);
}

KMeansResult equal_size_kmeans(std::span<const Vec3> points, std::span<const std::int64_t> weights, int k,
                               std::uint64_t seed, int max_iterations) {
  if (!weights.empty() && weights.size() != points.size())
    throw GridError("equal_size_kmeans: " + std::to_string(weights.size()) + " weights for " +
                    std::to_string(points.size()) + " points");
  for (std::int64_t w : weights)
    if (w < 1) throw GridError("equal_size_kmeans: a weight of " + std::to_string(w) + " (each must be >= 1)");
  // All weights equal: the equal-size clustering, label for label.
  if (std::adjacent_find(weights.begin(), weights.end(), std::not_equal_to<>()) == weights.end()) weights = {};
  if (k < 1) throw GridError("equal_size_kmeans: k = " + std::to_string(k) + " must be >= 1");
  if (max_iterations < 1)
    throw GridError("equal_size_kmeans: max_iterations = " + std::to_string(max_iterations) +
                    " must be >= 1");
  KMeansResult result;
  if (points.empty()) {
    result.centroids.assign(static_cast<std::size_t>(k), Vec3::Zero());
    result.converged = true;
    return result;
  }
  std::mt19937_64 rng(seed);
  result.centroids = seed_centroids(points, k, rng);
  for (int it = 0; it < max_iterations; ++it) {
    std::vector<int> labels = assign(points, weights, result.centroids);
    ++result.iterations;
    const bool same = labels == result.labels;
    result.labels = std::move(labels);
    if (same) {
      result.converged = true;
      break;
    }
    update_centroids(points, result.labels, result.centroids);
  }
  return result;
}

}  // namespace soda
