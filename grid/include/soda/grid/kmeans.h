// Equal-size k-means, the clustering the thesis uses to seed territories
// (3.2.4: "a sequential equal-sized EKMeans algorithm").
//
// Invariants (kept by equal_size_kmeans):
//  1. cluster sizes differ by at most one: n mod k clusters hold ceil(n/k)
//     points, the others floor(n/k);
//  2. the result depends only on the points (in the order given), k, the seed
//     and the iteration cap: the random draws come from std::mt19937_64 (whose
//     output sequence the standard fixes) without std distributions, every
//     sort has a total order, and sums run in point order.
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "soda/scene/scene.h"

namespace soda {

/// Result of equal_size_kmeans.
struct KMeansResult {
  std::vector<int> labels;      // per point, cluster 0 .. k-1
  std::vector<Vec3> centroids;  // per cluster, mean of its points (its seed if empty)
  int iterations = 0;           // assignment rounds run
  bool converged = false;       // true if the last round changed no label
};

/// Clusters points (metres) into k clusters of equal size (invariant 1):
/// k-means++ seeding, then rounds of a size-constrained assignment (points
/// with the strongest preference first, each to its nearest cluster that
/// still has room) and centroid updates, until no label changes or
/// max_iterations rounds ran. Throws GridError if k < 1 or
/// max_iterations < 1. Pure function; thread-safe.
KMeansResult equal_size_kmeans(std::span<const Vec3> points, int k, std::uint64_t seed,
                               int max_iterations);

/// Equal-weight k-means: as above, but a cluster has room while the weights
/// of its points stay below ceil(W / k), W the sum of the weights (each
/// weight >= 1), so no cluster exceeds that by as much as the largest
/// weight. With all weights equal it is the equal-size clustering above,
/// label for label. Throws GridError as above, or if weights.size() !=
/// points.size() or a weight is < 1.
KMeansResult equal_size_kmeans(std::span<const Vec3> points, std::span<const std::int64_t> weights, int k,
                               std::uint64_t seed, int max_iterations);

}  // namespace soda
