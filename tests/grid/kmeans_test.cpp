// equal_size_kmeans: equal sizes, determinism, sensible clusters.
#include <algorithm>
#include <random>

#include "grid/grid_test_util.h"
#include "soda/grid/kmeans.h"

namespace soda {
namespace {

std::vector<Vec3> random_points(int n, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::vector<Vec3> pts;
  for (int i = 0; i < n; ++i)
    pts.emplace_back(test::uniform(rng, -10, 10), test::uniform(rng, -10, 10),
                     test::uniform(rng, -10, 10));
  return pts;
}

std::vector<int> sizes(const KMeansResult& r, int k) {
  std::vector<int> s(static_cast<std::size_t>(k), 0);
  for (int label : r.labels) {
    EXPECT_GE(label, 0);
    EXPECT_LT(label, k);
    ++s[static_cast<std::size_t>(label)];
  }
  return s;
}

TEST(EqualSizeKMeans, ClusterSizesDifferByAtMostOne) {
  for (const auto& [n, k] : std::vector<std::pair<int, int>>{
           {100, 3}, {1000, 16}, {7, 3}, {5, 8}, {64, 64}, {1, 1}, {999, 4}, {10, 1}}) {
    const std::vector<Vec3> pts = random_points(n, 42 + static_cast<std::uint64_t>(n));
    const KMeansResult r = equal_size_kmeans(pts, k, 1, 100);
    ASSERT_EQ(r.labels.size(), static_cast<std::size_t>(n));
    ASSERT_EQ(r.centroids.size(), static_cast<std::size_t>(k));
    const std::vector<int> s = sizes(r, k);
    const auto [lo, hi] = std::minmax_element(s.begin(), s.end());
    EXPECT_LE(*hi - *lo, 1) << "n=" << n << " k=" << k;
    EXPECT_EQ(*lo, n / k) << "n=" << n << " k=" << k;
  }
}

TEST(EqualSizeKMeans, ClusteredPointsStayEqualSized) {
  // 70 % of the points in one blob: equal sizes force that blob to be split.
  std::vector<Vec3> pts = random_points(700, 5);
  for (Vec3& p : pts) p *= 0.1;
  for (const Vec3& p : random_points(300, 6)) pts.push_back(p + Vec3(40, 0, 0));
  const KMeansResult r = equal_size_kmeans(pts, 4, 9, 100);
  for (int s : sizes(r, 4)) EXPECT_EQ(s, 250);
}

TEST(EqualSizeKMeans, SeparatedEqualBlobsAreFoundExactly) {
  std::vector<Vec3> pts;
  const Vec3 centres[3] = {Vec3(-50, 0, 0), Vec3(50, 0, 0), Vec3(0, 80, 0)};
  for (const Vec3& c : centres)
    for (const Vec3& p : random_points(50, 11)) pts.push_back(c + 0.2 * p);
  const KMeansResult r = equal_size_kmeans(pts, 3, 3, 100);
  EXPECT_TRUE(r.converged);
  for (int blob = 0; blob < 3; ++blob)
    for (int i = 1; i < 50; ++i)
      EXPECT_EQ(r.labels[static_cast<std::size_t>(blob * 50 + i)],
                r.labels[static_cast<std::size_t>(blob * 50)]);
  EXPECT_NE(r.labels[0], r.labels[50]);
  EXPECT_NE(r.labels[0], r.labels[100]);
  EXPECT_NE(r.labels[50], r.labels[100]);
}

TEST(EqualSizeKMeans, DeterministicForASeed) {
  const std::vector<Vec3> pts = random_points(500, 77);
  const KMeansResult a = equal_size_kmeans(pts, 7, 123, 50);
  const KMeansResult b = equal_size_kmeans(pts, 7, 123, 50);
  EXPECT_EQ(a.labels, b.labels);
  EXPECT_EQ(a.iterations, b.iterations);
  for (std::size_t c = 0; c < a.centroids.size(); ++c) EXPECT_EQ(a.centroids[c], b.centroids[c]);
}

TEST(EqualSizeKMeans, RejectsBadParameters) {
  const std::vector<Vec3> pts = random_points(10, 1);
  test::expect_grid_error([&] { equal_size_kmeans(pts, 0, 1, 10); }, {"k = 0"});
  test::expect_grid_error([&] { equal_size_kmeans(pts, 2, 1, 0); }, {"max_iterations"});
  EXPECT_TRUE(equal_size_kmeans({}, 3, 1, 10).labels.empty());
}

}  // namespace
}  // namespace soda
