// spatial::KdTree against brute force: nearest, k nearest, radius and count queries on random
// points, on a lattice (many exact ties) and with duplicated points, in double and float.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <set>

#include "autoscan/core/random.hpp"
#include "autoscan/spatial/kdtree.hpp"

using namespace autoscan;
using namespace autoscan::spatial;

namespace {

// The squared distance as nanoflann's L2_Simple_Adaptor sums it (x, then y, then z), so that the
// oracle's values are bitwise those of the tree.
template <class P>
typename P::Scalar dist2(const P& a, const P& b) {
  typename P::Scalar s = 0;
  for (int d = 0; d < 3; ++d) {
    const auto t = a[d] - b[d];
    s += t * t;
  }
  return s;
}

template <class P>
std::vector<typename P::Scalar> sorted_distances(const std::vector<P>& pts, const P& q) {
  std::vector<typename P::Scalar> d;
  for (const auto& p : pts) d.push_back(dist2(p, q));
  std::sort(d.begin(), d.end());
  return d;
}

/// Checks knn(q, k) against brute force: the distances are the k smallest (ties included), every
/// index is distinct and its distance is the one reported, nearest first.
template <class Tree, class P>
void expect_knn(const Tree& tree, const std::vector<P>& pts, const P& q, std::size_t k) {
  using S = typename P::Scalar;
  const auto all = sorted_distances(pts, q);
  std::vector<std::size_t> idx(k);
  std::vector<S> d2(k);
  const std::size_t m = tree.knn(q, k, idx.data(), d2.data());
  ASSERT_EQ(m, std::min(k, pts.size()));
  std::set<std::size_t> seen;
  for (std::size_t j = 0; j < m; ++j) {
    EXPECT_EQ(d2[j], all[j]) << "rank " << j;
    ASSERT_LT(idx[j], pts.size());
    EXPECT_EQ(dist2(pts[idx[j]], q), d2[j]);
    EXPECT_TRUE(seen.insert(idx[j]).second) << "index " << idx[j] << " twice";
    if (j > 0) {
      EXPECT_LE(d2[j - 1], d2[j]);
    }
  }
  // The uint32 and vector forms give the same answer.
  std::vector<std::uint32_t> idx32(k);
  std::vector<S> e2(k);
  ASSERT_EQ(tree.knn(q, k, idx32.data(), e2.data()), m);
  std::vector<std::size_t> vidx;
  std::vector<S> vd2;
  ASSERT_EQ(tree.knn(q, k, vidx, vd2), m);
  ASSERT_EQ(vidx.size(), m);
  for (std::size_t j = 0; j < m; ++j) {
    EXPECT_EQ(idx32[j], idx[j]);
    EXPECT_EQ(vidx[j], idx[j]);
    EXPECT_EQ(e2[j], d2[j]);
  }
}

/// Checks radius(q, r) and count_within(q, r) against brute force (strictly inside r).
template <class Tree, class P>
void expect_radius(const Tree& tree, const std::vector<P>& pts, const P& q, typename P::Scalar r) {
  using S = typename P::Scalar;
  std::set<std::size_t> truth;
  for (std::size_t i = 0; i < pts.size(); ++i)
    if (dist2(pts[i], q) < r * r) truth.insert(i);
  std::vector<std::pair<KdTree::Index, S>> out;
  EXPECT_EQ(tree.radius(q, r, out), truth.size());
  ASSERT_EQ(out.size(), truth.size());
  std::set<std::size_t> got;
  for (const auto& [i, d] : out) {
    got.insert(i);
    EXPECT_EQ(d, dist2(pts[i], q));
  }
  EXPECT_EQ(got, truth);
  EXPECT_EQ(tree.count_within(q, r), truth.size());
}

std::vector<Vec3> random_points(std::size_t n, std::uint64_t seed) {
  Rng rng(seed);
  std::vector<Vec3> pts(n);
  for (auto& p : pts) p = Vec3(rng.uniform(), rng.uniform(), rng.uniform());
  return pts;
}

/// An n^3 integer lattice, every point twice (exact duplicates and exact distance ties everywhere).
std::vector<Vec3> lattice_with_duplicates(int n) {
  std::vector<Vec3> pts;
  for (int copy = 0; copy < 2; ++copy)
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) pts.emplace_back(i, j, k);
  return pts;
}

}  // namespace

// Moved from tests/registration (it tested the registration's own tree before the spatial floor).
TEST(Nearest, MatchesBruteForce) {
  Rng rng(3);
  std::vector<Vec3> pts(2000), qs(300);
  for (auto& p : pts) p = Vec3(rng.uniform(), rng.uniform(), rng.uniform());
  for (auto& q : qs) q = Vec3(rng.uniform(-0.2, 1.2), rng.uniform(), rng.uniform());
  KdTree nn(pts, 10);
  std::vector<std::size_t> idx(qs.size());
  std::vector<double> d2(qs.size());
  nn.nearest(qs, idx, d2);
  for (std::size_t i = 0; i < qs.size(); ++i) {
    double best = 1e300;
    for (const auto& p : pts) best = std::min(best, (p - qs[i]).squaredNorm());
    EXPECT_DOUBLE_EQ(d2[i], best);
    EXPECT_DOUBLE_EQ((pts[idx[i]] - qs[i]).squaredNorm(), best);
  }
  KdTree empty(std::vector<Vec3>{});
  EXPECT_EQ(empty.nearest(Vec3::Zero()), 0u);
}

TEST(KdTree, KnnAndRadiusMatchBruteForceOnRandomPoints) {
  const auto pts = random_points(3000, 11);
  Rng rng(12);
  for (std::size_t leaf : {1u, 10u, 16u, 64u}) {
    const KdTree tree(pts, leaf);
    EXPECT_EQ(tree.size(), pts.size());
    EXPECT_EQ(tree.leaf_size(), leaf);
    for (int t = 0; t < 60; ++t) {
      const Vec3 q(rng.uniform(-0.3, 1.3), rng.uniform(-0.3, 1.3), rng.uniform(-0.3, 1.3));
      for (std::size_t k : {1u, 2u, 7u, 30u}) expect_knn(tree, pts, q, k);
      for (double r : {0.0, 0.02, 0.1, 0.4}) expect_radius(tree, pts, q, r);
      double d2 = 0;
      const std::size_t i = tree.nearest(q, &d2);
      EXPECT_EQ(d2, sorted_distances(pts, q).front());
      EXPECT_EQ(dist2(pts[i], q), d2);
    }
  }
}

TEST(KdTree, TiesAndDuplicatesOnALattice) {
  const auto pts = lattice_with_duplicates(6);  // 432 points, each twice
  const KdTree tree(pts, 10);
  Rng rng(5);
  for (int t = 0; t < 80; ++t) {
    // Lattice points and half-integer points: many neighbours at exactly equal distances.
    const Vec3 q =
        t % 2 ? Vec3(double(rng.uniform_int(6)), double(rng.uniform_int(6)), double(rng.uniform_int(6)))
              : Vec3(double(rng.uniform_int(6)) + 0.5, double(rng.uniform_int(6)) + 0.5, double(rng.uniform_int(6)));
    for (std::size_t k : {1u, 2u, 3u, 8u, 13u, 27u, 1000u}) expect_knn(tree, pts, q, k);
    // Radii exactly at lattice distances: the boundary is excluded (squared distance < r^2).
    for (double r : {1.0, std::sqrt(2.0), 2.0, 2.5}) expect_radius(tree, pts, q, r);
  }
  // Equal point sets and leaf sizes give equal answers, tie order included.
  const KdTree again(pts, 10);
  std::vector<std::size_t> a(27), b(27);
  std::vector<double> da(27), db(27);
  tree.knn(Vec3(2, 2, 2), 27, a.data(), da.data());
  again.knn(Vec3(2, 2, 2), 27, b.data(), db.data());
  EXPECT_EQ(a, b);
}

TEST(KdTree, KnnOfPointExcludesItselfAmongDuplicates) {
  auto pts = lattice_with_duplicates(4);
  // A point with four more copies of itself: more than k + 1 = 4 duplicates.
  for (int c = 0; c < 4; ++c) pts.emplace_back(1, 1, 1);
  const KdTree tree(pts, 10);
  const std::size_t k = 3;
  std::vector<std::size_t> idx(k + 1);
  std::vector<double> d2(k + 1);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const std::size_t m = tree.knn_of_point(i, k, idx.data(), d2.data());
    ASSERT_EQ(m, k);
    // The k smallest distances to the OTHER points.
    std::vector<double> others;
    for (std::size_t j = 0; j < pts.size(); ++j)
      if (j != i) others.push_back(dist2(pts[j], pts[i]));
    std::sort(others.begin(), others.end());
    for (std::size_t j = 0; j < m; ++j) {
      EXPECT_NE(idx[j], i);
      EXPECT_EQ(d2[j], others[j]);
      EXPECT_EQ(dist2(pts[idx[j]], pts[i]), d2[j]);
    }
  }
}

TEST(KdTree, FloatPointsMatchBruteForce) {
  Rng rng(21);
  std::vector<Vec3f> pts(2500);
  for (auto& p : pts) p = Vec3(rng.uniform(), rng.uniform(), rng.uniform()).cast<float>();
  // Some exact duplicates.
  for (int i = 0; i < 100; ++i) pts.push_back(pts[static_cast<std::size_t>(i) * 7]);
  const KdTreeF tree(pts);
  for (int t = 0; t < 60; ++t) {
    const Vec3f q = Vec3(rng.uniform(), rng.uniform(), rng.uniform()).cast<float>();
    for (std::size_t k : {1u, 5u, 20u}) expect_knn(tree, pts, q, k);
    for (float r : {0.01f, 0.05f, 0.2f}) expect_radius(tree, pts, q, r);
  }
}

TEST(KdTree, OwnsMovedPointsAndHandlesEmptySets) {
  auto pts = random_points(500, 3);
  const auto copy = pts;
  KdTree owned(std::move(pts));
  pts.assign(10, Vec3::Constant(9));  // the tree does not refer to the moved-from vector
  ASSERT_EQ(owned.points().size(), copy.size());
  EXPECT_TRUE(std::equal(copy.begin(), copy.end(), owned.points().begin()));
  KdTree moved = std::move(owned);  // moving the tree keeps its points
  expect_knn(moved, copy, Vec3(0.5, 0.5, 0.5), 9);

  const std::vector<Vec3> none;
  const KdTree empty(none);
  EXPECT_TRUE(empty.empty());
  double d2 = 0;
  EXPECT_EQ(empty.nearest(Vec3::Zero(), &d2), 0u);
  EXPECT_EQ(d2, std::numeric_limits<double>::infinity());
  std::vector<std::size_t> idx;
  std::vector<double> dd;
  EXPECT_EQ(empty.knn(Vec3::Zero(), 4, idx, dd), 0u);
  EXPECT_TRUE(idx.empty());
  std::vector<std::pair<KdTree::Index, double>> out(3);
  EXPECT_EQ(empty.radius(Vec3::Zero(), 1.0, out), 0u);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(empty.count_within(Vec3::Zero(), 1.0), 0u);
  // k = 0 and k larger than the set.
  const KdTree small(copy);
  EXPECT_EQ(small.knn(Vec3::Zero(), 0, idx, dd), 0u);
  EXPECT_EQ(small.knn(Vec3::Zero(), 10000, idx, dd), copy.size());
}
