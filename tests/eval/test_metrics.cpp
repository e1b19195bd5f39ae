#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "autoscan/core/error.hpp"
#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/eval/metrics.hpp"
#include "autoscan/shapes/primitives.hpp"
#include "autoscan/shapes/procedural.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "support/temp_dir.hpp"

using namespace autoscan;
using namespace autoscan::eval;
namespace fs = std::filesystem;

namespace {

EvalOptions fast_options() {
  EvalOptions o;
  o.samples = 40000;
  return o;
}

// Faces of `m` whose centroid has z > 0 (an open half sphere).
TriangleMesh upper_half(const TriangleMesh& m) {
  TriangleMesh h;
  h.vertices = m.vertices;
  for (const auto& f : m.faces)
    if ((m.vertices[f[0]] + m.vertices[f[1]] + m.vertices[f[2]]).z() > 0) h.faces.push_back(f);
  return h;
}

// Below the test process's scratch root, removed when the process exits (support/temp_dir.hpp).
fs::path temp_dir() { return autoscan::testing::shared_scratch_dir("eval"); }

}  // namespace

TEST(EvaluateMesh, ConcentricSpheresGiveTheRadiusDifference) {
  const double delta = 0.01;
  // Icospheres of 81920 faces: chord sagitta about 2e-5 at radius 0.5.
  const TriangleMesh truth = icosphere(0.5, 6), recon = icosphere(0.5 + delta, 6);
  const EvalResult r = evaluate_mesh(recon, truth, fast_options());
  const double tess = 1e-4;
  EXPECT_NEAR(r.accuracy.mean, delta, tess);
  EXPECT_NEAR(r.accuracy.max, delta, tess);
  EXPECT_NEAR(r.accuracy.median, delta, tess);
  EXPECT_NEAR(r.accuracy.rms, delta, tess);
  EXPECT_NEAR(r.completeness.mean, delta, tess);
  EXPECT_NEAR(r.completeness.p99, delta, tess);
  EXPECT_NEAR(r.truth_diagonal, std::sqrt(3.0), 1e-3);
  // tau_abs = 0.005 * sqrt(3) ≈ 0.00866 < delta: nothing is within tau.
  EXPECT_EQ(r.precision, 0.0);
  EXPECT_EQ(r.fscore, 0.0);
  // With tau above delta, everything is.
  EvalOptions o = fast_options();
  o.tau = 0.007;  // 0.0121 absolute
  const EvalResult r2 = evaluate_mesh(recon, truth, o);
  EXPECT_EQ(r2.precision, 1.0);
  EXPECT_EQ(r2.recall, 1.0);
  EXPECT_EQ(r2.fscore, 1.0);
  // All samples are in the histogram bin that holds delta.
  const auto& h = r.histogram;
  ASSERT_EQ(h.share.size(), 20u);
  const auto bin = static_cast<std::size_t>(delta / (h.edges[1] - h.edges[0]));
  EXPECT_NEAR(h.share[bin], 1.0, 1e-3);
}

TEST(EvaluateMesh, MeshAgainstItselfIsPerfect) {
  const TriangleMesh m = icosphere(0.5, 4);
  const EvalResult r = evaluate_mesh(m, m, fast_options());
  EXPECT_LT(r.accuracy.max, 1e-12);
  EXPECT_LT(r.completeness.max, 1e-12);
  EXPECT_EQ(r.precision, 1.0);
  EXPECT_EQ(r.recall, 1.0);
  EXPECT_EQ(r.fscore, 1.0);
  EXPECT_NEAR(r.histogram.share[0], 1.0, 1e-12);
  EXPECT_EQ(r.histogram.overflow, 0.0);
}

TEST(EvaluateMesh, HalfSphereIsPreciseButIncomplete) {
  const TriangleMesh truth = icosphere(0.5, 5);
  const TriangleMesh half = upper_half(truth);
  const EvalResult r = evaluate_mesh(half, truth, fast_options());
  EXPECT_EQ(r.precision, 1.0);
  EXPECT_NEAR(r.recall, 0.5, 0.03);
  EXPECT_NEAR(r.fscore, 2 * 0.5 / 1.5, 0.03);
  EXPECT_LT(r.accuracy.max, 1e-12);
  // The bottom pole is 0.5·sqrt(2) from the rim.
  EXPECT_NEAR(r.completeness.max, 0.5 * std::sqrt(2.0), 0.01);
  EXPECT_GT(r.completeness.mean, 0.1);
}

TEST(EvaluateMesh, DeterministicAndSerialisable) {
  const TriangleMesh truth = icosphere(0.5, 4), recon = icosphere(0.51, 3);
  const EvalResult a = evaluate_mesh(recon, truth, fast_options());
  const EvalResult b = evaluate_mesh(recon, truth, fast_options());
  EXPECT_EQ(a.accuracy.mean, b.accuracy.mean);
  EXPECT_EQ(a.completeness.p90, b.completeness.p90);
  EXPECT_EQ(a.histogram.counts, b.histogram.counts);
  const auto j = a.to_json();
  EXPECT_EQ(j.at("fscore").get<double>(), a.fscore);
  EXPECT_EQ(j.at("accuracy").at("p99").get<double>(), a.accuracy.p99);
  EXPECT_EQ(j.at("histogram").at("share").size(), 20u);
  EXPECT_EQ(j.at("tau").get<double>(), 0.005);
}

TEST(EvaluateMesh, RejectsBadInput) {
  const TriangleMesh m = icosphere(0.5, 1);
  EvalOptions o;
  o.tau = 0;
  EXPECT_THROW(evaluate_mesh(m, m, o), InputError);
  o = EvalOptions{};
  o.samples = 0;
  EXPECT_THROW(evaluate_mesh(m, m, o), InputError);
  o = EvalOptions{};
  o.histogram_bins = 0;
  EXPECT_THROW(evaluate_mesh(m, m, o), InputError);
  EXPECT_THROW(evaluate_mesh(TriangleMesh{}, m), InputError);
  EXPECT_THROW(evaluate_mesh(m, TriangleMesh{}), InputError);
}

TEST(Coverage, DenseSamplesCoverAndHalfCoversHalf) {
  const TriangleMesh sphere = icosphere(0.5, 5);
  Rng rng(77);
  const PointCloud dense = sample_surface(sphere, 200000, rng);
  EXPECT_GT(coverage(dense, sphere, 0.005, 50000), 0.999);
  PointCloud half;
  for (const auto& p : dense.positions)
    if (p.z() > 0) half.positions.push_back(p);
  // Half the sphere plus a band of width tau_abs (0.0087) above the equator: 0.5 + 0.0087/1 ≈ 0.509.
  EXPECT_NEAR(coverage(half, sphere, 0.005, 50000), 0.5, 0.02);
  EXPECT_EQ(coverage(PointCloud{}, sphere), 0.0);
}

// Dense samples of a sphere of radius 0.5, its upper half (z > 0) and its lower cap (z < -0.25).
struct SphereParts {
  PointCloud dense, upper, lower_cap;
  SphereParts(const TriangleMesh& sphere, std::size_t n, std::uint64_t seed) {
    Rng rng(seed);
    dense = sample_surface(sphere, n, rng);
    for (const auto& p : dense.positions) {
      if (p.z() > 0) upper.positions.push_back(p);
      if (p.z() < -0.25) lower_cap.positions.push_back(p);
    }
  }
};

TEST(Coverage, SplitByTheScannableReference) {
  const TriangleMesh sphere = icosphere(0.5, 5);
  const auto [dense, upper, lower_cap] = SphereParts(sphere, 200000, 78);
  // Scanned everything, only the upper half scannable: all of the scannable part is covered.
  auto c = coverage_split(dense, upper, sphere, 0.005, 50000);
  EXPECT_GT(c.coverage, 0.999);
  EXPECT_NEAR(c.scannable_share, 0.5, 0.02);
  EXPECT_GT(c.scannable_coverage, 0.999);
  // Scanned the upper half, everything scannable: the split agrees with coverage().
  c = coverage_split(upper, dense, sphere, 0.005, 50000);
  EXPECT_DOUBLE_EQ(c.coverage, coverage(upper, sphere, 0.005, 50000));
  EXPECT_GT(c.scannable_share, 0.999);
  EXPECT_NEAR(c.scannable_coverage, c.coverage, 1e-3);
  // Scanned the upper half, scannable only the lower cap (area share (1 - 0.5) / 2 = 0.25): none of
  // the scannable part is covered.
  c = coverage_split(upper, lower_cap, sphere, 0.005, 50000);
  EXPECT_NEAR(c.scannable_share, 0.25, 0.02);
  EXPECT_EQ(c.scannable_coverage, 0.0);
  // Nothing scannable: the scannable coverage is vacuously complete.
  PointCloud far_away;
  far_away.positions.push_back(Vec3(10, 10, 10));
  EXPECT_EQ(coverage_split(upper, far_away, sphere, 0.005, 5000).scannable_coverage, 1.0);
}

// The probe (the per-view coverage curve) is coverage_split() with its samples drawn once: the same
// numbers, bit for bit, for every scanned cloud and with or without a reference.
TEST(Coverage, ProbeEqualsCoverageSplit) {
  const TriangleMesh sphere = icosphere(0.5, 4);
  const auto [dense, upper, lower_cap] = SphereParts(sphere, 60000, 79);
  const CoverageProbe probe(sphere, &upper, 0.005, 20000, 3);
  EXPECT_EQ(probe.samples(), 20000u);
  for (const PointCloud* scanned : std::vector<const PointCloud*>{&dense, &upper, &lower_cap}) {
    const auto a = probe.measure(*scanned);
    const auto b = coverage_split(*scanned, upper, sphere, 0.005, 20000, 3);
    EXPECT_EQ(a.coverage, b.coverage);
    EXPECT_EQ(a.scannable_share, b.scannable_share);
    EXPECT_EQ(a.scannable_coverage, b.scannable_coverage);
  }
  EXPECT_EQ(probe.measure(PointCloud{}).coverage, 0.0);
  EXPECT_EQ(probe.measure(PointCloud{}).scannable_coverage, 0.0);
  const CoverageProbe all(sphere, nullptr, 0.005, 20000, 3);
  EXPECT_EQ(all.measure(upper).coverage, coverage(upper, sphere, 0.005, 20000, 3));
  EXPECT_EQ(all.measure(upper).scannable_coverage, all.measure(upper).coverage);
  EXPECT_EQ(all.measure(upper).scannable_share, 1.0);
}

TEST(EvaluateCloud, PointsOnALargerSphere) {
  const TriangleMesh truth = icosphere(0.5, 6);
  Rng rng(5);
  PointCloud pc = sample_surface(icosphere(1.0, 6), 200000, rng);
  for (auto& p : pc.positions) p *= 0.5 + 0.004;  // 0.004 outside: within tau_abs 0.0087
  const CloudEvalResult r = evaluate_cloud(pc, truth, fast_options());
  EXPECT_EQ(r.points, 200000u);
  EXPECT_NEAR(r.accuracy.mean, 0.004, 1e-4);
  EXPECT_EQ(r.precision, 1.0);
  EXPECT_GT(r.coverage, 0.99);
  EXPECT_GT(r.fscore, 0.99);
  EXPECT_TRUE(r.to_json().contains("coverage"));
}

TEST(Histogram, SharesAndWriters) {
  const std::vector<double> d = {0.0, 0.001, 0.0011, 0.0049, 0.005, 0.02, 1.0};
  const ErrorHistogram h = make_histogram(d, 4, 0.01, 2.0);  // edges 0, .005, .01, .015, .02
  ASSERT_EQ(h.edges.size(), 5u);
  EXPECT_DOUBLE_EQ(h.edges.back(), 0.02);
  EXPECT_EQ(h.counts, (std::vector<std::size_t>{4, 1, 0, 0}));
  EXPECT_EQ(h.overflow_count, 2u);
  double total = h.overflow;
  for (double s : h.share) total += s;
  EXPECT_NEAR(total, 1.0, 1e-12);

  const fs::path dir = temp_dir();
  write_histogram_csv(dir / "h.csv", h);
  std::ifstream in(dir / "h.csv");
  std::string line;
  int lines = 0;
  std::getline(in, line);
  EXPECT_EQ(line, "bin_lo,bin_hi,share,count");
  while (std::getline(in, line)) ++lines;
  EXPECT_EQ(lines, 5);

  write_histogram_svg(dir / "h.svg", {{"ours", h}, {"a<b", h}}, "Figure 9");
  std::stringstream svg;
  svg << std::ifstream(dir / "h.svg").rdbuf();
  EXPECT_NE(svg.str().find("<svg"), std::string::npos);
  EXPECT_NE(svg.str().find("a&lt;b"), std::string::npos);
  EXPECT_NE(svg.str().find("</svg>"), std::string::npos);

  // Mismatched bins: error, nothing written.
  const ErrorHistogram other = make_histogram(d, 5, 0.01, 2.0);
  EXPECT_THROW(write_histogram_svg(dir / "bad.svg", {{"a", h}, {"b", other}}), InputError);
  EXPECT_FALSE(fs::exists(dir / "bad.svg"));
  // Missing directory: error, nothing written.
  EXPECT_THROW(write_histogram_csv(dir / "missing" / "h.csv", h), Error);
  fs::remove_all(dir);
}

// The report's histogram: bin 0 below range·1e-3, then three decades on log-spaced edges.
TEST(Histogram, LogBinsSpreadAGoodScanOverDecades) {
  // max 0.01 of a diagonal 2 → top 0.02, low 2e-5; 4 bins: edges 0, 2e-5, 2e-4, 2e-3, 2e-2.
  const std::vector<double> d = {0.0, 1e-5, 3e-5, 1e-4, 5e-4, 1.9e-3, 2.1e-3, 0.019, 0.02, 1.0};
  const ErrorHistogram h = make_log_histogram(d, 4, 0.01, 2.0);
  ASSERT_EQ(h.edges.size(), 5u);
  EXPECT_DOUBLE_EQ(h.edges[0], 0.0);
  EXPECT_NEAR(h.edges[1], 2e-5, 1e-18);
  EXPECT_NEAR(h.edges[2], 2e-4, 1e-17);
  EXPECT_NEAR(h.edges[3], 2e-3, 1e-16);
  EXPECT_DOUBLE_EQ(h.edges[4], 0.02);
  EXPECT_EQ(h.counts, (std::vector<std::size_t>{2, 2, 2, 2}));
  EXPECT_EQ(h.overflow_count, 2u);
  EXPECT_DOUBLE_EQ(h.share[0], 0.2);
  EXPECT_DOUBLE_EQ(h.overflow, 0.2);
  // The linear bins put the first eight of them in one bin.
  EXPECT_EQ(make_histogram(d, 4, 0.01, 2.0).counts[0], 7u);
  EXPECT_THROW(make_log_histogram(d, 1, 0.01, 2.0), InputError);
  EXPECT_THROW(make_log_histogram(d, 4, 0.0, 2.0), InputError);
}

TEST(ProceduralObject, SdfIsABoundOnTheDistanceToItsMesh) {
  const ProceduralObject obj;
  const TriangleMesh m = obj.mesh(120);
  const MeshDistance md(m);
  Rng rng(21);
  const AABB b = obj.bounds();
  for (int i = 0; i < 3000; ++i) {
    const Vec3 p(rng.uniform(b.min.x() - 0.05, b.max.x() + 0.05), rng.uniform(b.min.y() - 0.05, b.max.y() + 0.05),
                 rng.uniform(b.min.z() - 0.05, b.max.z() + 0.05));
    // |sdf| may not exceed the distance to the surface (the mesh is within ~1e-3 of it).
    EXPECT_LE(std::abs(obj.sdf(p)), md.distance(p) + 2e-3);
  }
}

// ---- colour error (docs/colour.md) ---------------------------------------------------------------

TEST(ColorError, IsTheRgbDistanceToTheTruthColourAtTheNearestPoint) {
  // Truth: a quad, left half red, right half blue (separate vertices). Reconstruction: points just
  // above it, coloured with a known offset.
  TriangleMesh truth;
  truth.vertices = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(1, 1, 0), Vec3(0, 1, 0)};
  truth.faces = {{0, 1, 2}, {0, 2, 3}};
  truth.vertex_colors = {Rgb{0, 0, 0}, Rgb{200, 0, 0}, Rgb{200, 0, 0}, Rgb{0, 0, 0}};  // red ramp along x
  TriangleMesh recon;
  recon.vertices = {Vec3(0.25, 0.5, 0.001), Vec3(0.75, 0.5, 0.001), Vec3(0.5, 0.2, 0.001), Vec3(0.5, 0.5, 0.5)};
  recon.faces = {{0, 1, 2}};
  // Truth colours there: 50, 150, 100 in red. Offsets (3, 4, 0) → 5, (0, 0, 12) → 12, exact → 0.
  recon.vertex_colors = {Rgb{53, 4, 0}, Rgb{150, 0, 12}, Rgb{100, 0, 0}, Rgb{255, 255, 255}};
  const auto e = eval::color_error(recon, truth, 0.01);
  EXPECT_EQ(e.vertices, 3u);  // the vertex 0.5 above the truth is not counted
  EXPECT_NEAR(e.counted_share, 0.75, 1e-12);
  EXPECT_NEAR(e.mean, (5.0 + 12.0 + 0.0) / 3.0, 1e-9);
  EXPECT_NEAR(e.median, 5.0, 1e-9);
  TriangleMesh bare = recon;
  bare.vertex_colors.clear();
  EXPECT_THROW(eval::color_error(bare, truth), InputError);
  TriangleMesh grey = truth;
  grey.vertex_colors.clear();
  EXPECT_THROW(eval::color_error(recon, grey), InputError);
}
