// Confidence map (paper §4.2, Eq. 1-3) against analytic oracles: smoothed indicator fields of a sphere
// and a plane whose gradient is known, raw points sampled on known surfaces, brute-force kNN.
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cmath>
#include <numeric>

#include "autoscan/confidence/confidence.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/io/colormap.hpp"
#include "fields.hpp"

using namespace autoscan;
using namespace autoscan::confidence;
using namespace autoscan::testing;

namespace {

double mean_where(const std::vector<double>& v, const std::vector<Vec3>& p,
                  const std::function<bool(const Vec3&)>& sel) {
  double s = 0;
  int n = 0;
  for (std::size_t i = 0; i < v.size(); ++i)
    if (sel(p[i])) {
      s += v[i];
      ++n;
    }
  return n ? s / n : std::nan("");
}

// Brute-force Eq. 2 at s with unit normal n over all raw points.
double brute_fs(const std::vector<Vec3>& raw, const Vec3& s, const Vec3& n, int k, double a, double b) {
  std::vector<std::pair<double, std::size_t>> d;
  for (std::size_t j = 0; j < raw.size(); ++j) d.emplace_back((raw[j] - s).squaredNorm(), j);
  std::partial_sort(d.begin(), d.begin() + k, d.end());
  const double h = std::sqrt(d[static_cast<std::size_t>(k - 1)].first);
  double sum = 0;
  for (int j = 0; j < k; ++j) {
    const Vec3& q = raw[d[static_cast<std::size_t>(j)].second];
    const double theta = std::exp(-(q - s).squaredNorm() / std::pow(h / a, 2));
    const double phi = std::exp(-std::pow(n.dot(q - s), 2) / std::pow(h / b, 2));
    sum += theta * phi;
  }
  return sum;
}

ConfidenceOptions small_options(std::size_t count = 1500) {
  ConfidenceOptions o;
  o.iso.count = count;
  return o;
}

}  // namespace

TEST(PlaneSmoothness, AnalyticValueMatchesFormulaAndBriefApproximation) {
  const double e4 = std::exp(-4.0);
  EXPECT_NEAR(plane_smoothness(100, 2.0), 99 * (1 - e4) / 4 + e4, 1e-12);
  EXPECT_NEAR(plane_smoothness(100, 2.0), 24.3150, 1e-3);
  // The brief's K(1 − e^{−4})/4 ignores that the K-th neighbour sits exactly at h: within 1 %.
  EXPECT_NEAR(plane_smoothness(100, 2.0) / (100 * (1 - e4) / 4), 1.0, 0.01);
  EXPECT_NEAR(plane_smoothness(1, 2.0), e4, 1e-15);
}

TEST(PlaneSmoothness, MonteCarloOnUniformPlaneMatchesAnalyticValue) {
  // A Poisson process on the plane: given the K-th neighbour distance h, the other K − 1 neighbours are
  // uniform in the disc of radius h, so the mean raw f_s over many queries is plane_smoothness(K).
  const PointCloud raw = noisy_plane(200000, 1.0, 0.0, 7);
  ConfidenceEvaluator ev(raw);
  Rng rng(3);
  std::vector<Vec3> q, n;
  for (int i = 0; i < 4000; ++i) {
    q.emplace_back(rng.uniform(-0.8, 0.8), rng.uniform(-0.8, 0.8), 0.0);
    n.emplace_back(0, 0, -1);
  }
  const auto fs = ev.smoothness(q, n);
  const double mean = std::accumulate(fs.begin(), fs.end(), 0.0) / static_cast<double>(fs.size());
  EXPECT_NEAR(mean / plane_smoothness(100, 2.0), 1.0, 0.01);
}

TEST(Smoothness, MatchesBruteForceEq2) {
  PointCloud raw = noisy_plane(3000, 1.0, 0.02, 11);
  ConfidenceOptions o;
  o.k = 37;
  o.theta_divisor = 1.7;
  o.phi_divisor = 3.3;
  ConfidenceEvaluator ev(raw, o);
  Rng rng(5);
  std::vector<Vec3> q, n;
  for (int i = 0; i < 60; ++i) {
    q.emplace_back(rng.uniform(-1.1, 1.1), rng.uniform(-1.1, 1.1), rng.uniform(-0.05, 0.05));
    n.push_back(rng.unit_vector());
  }
  std::vector<double> h;
  const auto fs = ev.smoothness(q, n, &h);
  ASSERT_EQ(fs.size(), q.size());
  for (std::size_t i = 0; i < q.size(); ++i) {
    EXPECT_NEAR(fs[i], brute_fs(raw.positions, q[i], n[i], 37, 1.7, 3.3), 1e-9 * (1 + fs[i])) << i;
    EXPECT_GT(h[i], 0.0);
  }
  // The normal's sign does not matter.
  std::vector<Vec3> neg(n.size());
  std::transform(n.begin(), n.end(), neg.begin(), [](const Vec3& v) { return Vec3(-v); });
  const auto fs2 = ev.smoothness(q, neg);
  for (std::size_t i = 0; i < q.size(); ++i) EXPECT_NEAR(fs[i], fs2[i], 1e-12);
}

TEST(Confidence, PerfectPlaneGivesFsNearOneAndNoiseLowersIt) {
  const double eps = 0.01;
  const PlaneField field(eps);
  const TriangleMesh mesh = plane_mesh(0.5, 10);
  double prev = 2.0;
  for (double sigma : {0.0, 0.003, 0.01}) {
    // Same density (a jittered 450² grid on [−1, 1]², step 0.0044, h ≈ 0.025), increasing noise.
    const PointCloud raw = grid_plane(450, 1.0, 0.5, sigma, 21);
    const auto r = assess_confidence(field, mesh, raw, 1.0 / (4 * eps), small_options());
    EXPECT_NEAR(r.mean_f_g, 1.0, 1e-6);
    if (sigma == 0.0) {
      EXPECT_GT(r.mean_f_s, 0.98) << "a perfect plane must score f_s ≈ 1";
      EXPECT_NEAR(r.mean_f, r.mean_f_s, 1e-6);
    }
    EXPECT_LT(r.mean_f_s, prev) << "sigma " << sigma;
    prev = r.mean_f_s;
  }
  EXPECT_LT(prev, 0.75);
  // A uniform random (Poisson process) sampling of the plane has the analytic mean raw f_s, but its
  // spread (~10 %) is clipped at 1 by the mapping: still close to 1.
  const auto r = assess_confidence(field, mesh, noisy_plane(200000, 1.0, 0.0, 21), 1.0 / (4 * eps), small_options());
  EXPECT_GT(r.mean_f_s, 0.94);
}

TEST(Confidence, NoisierHalfHasLowerFsAtSameDensity) {
  // Figure 4 in miniature: one raw cloud of uniform density, clean for x < 0, noisy for x > 0.
  const PlaneField field(0.01);
  PointCloud raw = noisy_plane(200000, 1.0, 0.0, 31);
  Rng rng(4);
  for (auto& p : raw.positions)
    if (p.x() > 0) p.z() = rng.normal(0.0, 0.006);
  const auto r = assess_confidence(field, plane_mesh(0.6, 12), raw, 25.0, small_options());
  const auto& fs = r.iso_points.scalars.get("f_s");
  const double clean = mean_where(fs, r.iso_points.positions, [](const Vec3& p) { return p.x() < -0.1; });
  const double noisy = mean_where(fs, r.iso_points.positions, [](const Vec3& p) { return p.x() > 0.1; });
  EXPECT_GT(clean, 0.95);
  EXPECT_LT(noisy, clean - 0.15);
}

TEST(Confidence, UndersampledDetailHasLowerFs) {
  // Figure 4: the iso-surface is a plane (the reconstruction missed the detail), while the raw points
  // for x > 0 lie on fine bumps (z = A sin(ωx) sin(ωy)) that a K-neighbourhood spans several times.
  const PlaneField field(0.01);
  PointCloud raw = noisy_plane(200000, 1.0, 0.0, 41);
  for (auto& p : raw.positions)
    if (p.x() > 0) p.z() = 0.01 * std::sin(300 * p.x()) * std::sin(300 * p.y());
  const auto r = assess_confidence(field, plane_mesh(0.6, 12), raw, 25.0, small_options());
  const auto& fs = r.iso_points.scalars.get("f_s");
  const double smooth = mean_where(fs, r.iso_points.positions, [](const Vec3& p) { return p.x() < -0.1; });
  const double detail = mean_where(fs, r.iso_points.positions, [](const Vec3& p) { return p.x() > 0.1; });
  EXPECT_LT(detail, smooth - 0.2);
}

TEST(IsoPoints, ProjectedOntoIsoSurfaceWithFieldNormals) {
  const double r0 = 0.4;
  const SphereField field(r0, 0.01);
  // Mesh 2 % too large: the Newton steps must bring the samples onto |p| = r0.
  const TriangleMesh mesh = icosphere(r0 * 1.02, 4);
  IsoPointOptions o;
  o.count = 2000;
  const IsoPoints iso = sample_iso_points(field, mesh, o);
  ASSERT_EQ(iso.positions.size(), 2000u);
  for (std::size_t i = 0; i < iso.positions.size(); ++i) {
    const Vec3& p = iso.positions[i];
    EXPECT_NEAR(p.norm(), r0, 1e-5 * r0);
    EXPECT_GT(iso.inward_normals[i].dot(-p.normalized()), 1 - 1e-9);
    EXPECT_NEAR(iso.gradients[i].norm(), 1.0 / (4 * 0.01), 1e-3 * 25);
  }
  EXPECT_LT(iso.max_residual, 1e-5 * r0);
  EXPECT_GT(iso.max_displacement, 0.005);
  EXPECT_NEAR(iso.surface_area, 4 * M_PI * std::pow(r0 * 1.02, 2), 0.01 * 4 * M_PI * r0 * r0);
}

TEST(IsoPoints, PoissonDiskDistribution) {
  const TriangleMesh mesh = icosphere(0.4, 4);
  const SphereField field(0.4, 0.01);
  IsoPointOptions o;
  o.count = 3000;
  const IsoPoints iso = sample_iso_points(field, mesh, o);
  ASSERT_EQ(iso.positions.size(), 3000u);
  const double spacing = iso.spacing;
  // Nearest-neighbour distances: a Poisson-disk set has no close pairs and no holes; uniform random
  // sampling of the same count has many close pairs (tested below for contrast).
  auto nn_stats = [](const std::vector<Vec3>& p) {
    double mn = 1e9, mean = 0;
    for (std::size_t i = 0; i < p.size(); ++i) {
      double best = 1e9;
      for (std::size_t j = 0; j < p.size(); ++j)
        if (i != j) best = std::min(best, (p[i] - p[j]).norm());
      mn = std::min(mn, best);
      mean += best;
    }
    return std::pair{mn, mean / static_cast<double>(p.size())};
  };
  const auto [mn, mean] = nn_stats(iso.positions);
  EXPECT_GT(mn, 0.5 * spacing);
  EXPECT_GT(mean, 0.75 * spacing);
  EXPECT_LT(mean, 1.1 * spacing);
  // No holes: every mesh vertex is within ~1.2 spacings of an iso-point.
  double worst = 0;
  for (const auto& v : mesh.vertices) {
    double best = 1e9;
    for (const auto& p : iso.positions) best = std::min(best, (v - p).norm());
    worst = std::max(worst, best);
  }
  EXPECT_LT(worst, 1.2 * spacing);
  // Contrast: the first 3000 uniform candidates (candidate_factor 1 = no elimination).
  IsoPointOptions u = o;
  u.candidate_factor = 1.0;
  const auto [umn, umean] = nn_stats(sample_iso_points(field, mesh, u).positions);
  EXPECT_LT(umn, 0.1 * spacing);
  EXPECT_LT(umean, mean);
}

TEST(IsoPoints, SpacingOptionSetsCount) {
  const TriangleMesh mesh = plane_mesh(0.5, 4);  // area 1
  IsoPointOptions o;
  o.spacing = 0.02;
  const IsoPoints iso = sample_iso_points(PlaneField(0.01), mesh, o);
  EXPECT_NEAR(static_cast<double>(iso.positions.size()), 2.0 / (std::sqrt(3.0) * 0.02 * 0.02), 2.0);
  EXPECT_DOUBLE_EQ(iso.spacing, 0.02);
}

TEST(Confidence, CompletenessOnSphereIsGradientMagnitude) {
  const double eps = 0.01;
  const SphereField field(0.4, eps);
  const PointCloud raw = sphere_points(60000, 0.4, 0.0, 5);
  const auto r = assess_confidence(field, icosphere(0.4, 4), raw, 1.0 / (4 * eps), small_options());
  const auto& fg_raw = r.iso_points.scalars.get("f_g_raw");
  const auto& fg = r.iso_points.scalars.get("f_g");
  for (std::size_t i = 0; i < fg.size(); ++i) {
    EXPECT_NEAR(fg_raw[i], 1.0 / (4 * eps), 1e-3 * 25);  // Eq. 1: Γ·n_k = |Γ| = 1/(4ε)
    EXPECT_NEAR(fg[i], 1.0, 1e-3);
    EXPECT_NEAR(r.iso_points.normals[i].dot(r.iso_points.positions[i].normalized()), 1.0, 1e-9);  // outward
    EXPECT_NEAR((r.iso_points.normals[i] + r.inward_normals[i]).norm(), 0.0, 1e-12);
  }
  EXPECT_NEAR(r.mean_f_g, 1.0, 1e-3);
  EXPECT_GT(r.mean_f_s, 0.9);
  // A field twice as blurred everywhere halves the (absolute) completeness.
  const auto r2 =
      assess_confidence(SphereField(0.4, 2 * eps), icosphere(0.4, 4), raw, 1.0 / (4 * eps), small_options());
  EXPECT_NEAR(r2.mean_f_g, 0.5, 1e-3);
  EXPECT_NEAR(r2.mean_f, 0.5 * r.mean_f, 0.02);
}

TEST(Confidence, BlurredRegionHasLowFgAndIsSeparated) {
  // Figure 3 with an analytic field: ε grows from ε0 (z < 0) to 4ε0 (z > 0.5 r), like the blurry field
  // Poisson produces over missing data.
  const double eps0 = 0.01;
  auto eps = [eps0](const Vec3& u) {
    const double t = std::clamp(u.z() / 0.5, 0.0, 1.0);
    return eps0 * (1 + 3 * t * t * (3 - 2 * t));
  };
  const SphereField field(0.4, eps);
  const PointCloud raw = sphere_points(60000, 0.4, 0.0, 6);
  const auto r = assess_confidence(field, icosphere(0.4, 4), raw, 1.0 / (4 * eps0), small_options());
  const auto& fg = r.iso_points.scalars.get("f_g");
  std::vector<bool> blurred;
  for (std::size_t i = 0; i < fg.size(); ++i) {
    const Vec3& p = r.iso_points.positions[i];
    EXPECT_NEAR(fg[i], eps0 / field.eps_at(p), 2e-3);
    blurred.push_back(p.z() > 0.25 * 0.4);
  }
  EXPECT_GE(auc_low_is_positive(fg, blurred), 0.99);
  // The coloured mesh carries interpolated values close to the analytic ones.
  ASSERT_EQ(r.mesh.vertex_scalars.get("f_g").size(), r.mesh.vertices.size());
  ASSERT_EQ(r.mesh.vertex_colors.size(), r.mesh.vertices.size());
  const auto& vfg = r.mesh.vertex_scalars.get("f_g");
  double err_sum = 0;
  for (std::size_t v = 0; v < r.mesh.vertices.size(); ++v) {
    const double err = std::abs(vfg[v] - eps0 / field.eps_at(r.mesh.vertices[v]));
    EXPECT_LT(err, 0.1);  // 4 iso-points ~0.04 apart on a ramp of slope ~4 per unit length
    err_sum += err;
  }
  EXPECT_LT(err_sum / static_cast<double>(r.mesh.vertices.size()), 0.02);
  // Low confidence is blue, high is red (io::colormap), on the mesh and on the iso-points.
  std::size_t top = 0, bottom = 0;
  for (std::size_t v = 1; v < r.mesh.vertices.size(); ++v) {
    if (r.mesh.vertices[v].z() > r.mesh.vertices[top].z()) top = v;
    if (r.mesh.vertices[v].z() < r.mesh.vertices[bottom].z()) bottom = v;
  }
  EXPECT_GT(r.mesh.vertex_colors[top][2], r.mesh.vertex_colors[top][0]);
  EXPECT_GT(r.mesh.vertex_colors[bottom][0], r.mesh.vertex_colors[bottom][2]);
  const auto& f = r.iso_points.scalars.get("f");
  for (std::size_t i = 0; i < f.size(); ++i) EXPECT_EQ(r.iso_points.colors[i], io::colormap(f[i]));
}

TEST(Confidence, AbsoluteMapping) {
  EXPECT_DOUBLE_EQ(normalize_completeness(5.0, 10.0), 0.5);
  EXPECT_DOUBLE_EQ(normalize_completeness(50.0, 10.0), 1.0);
  EXPECT_DOUBLE_EQ(normalize_completeness(-1.0, 10.0), 0.0);
  EXPECT_DOUBLE_EQ(normalize_smoothness(12.0, 24.0), 0.5);
  EXPECT_THROW(normalize_completeness(1.0, 0.0), InputError);
  EXPECT_THROW(normalize_smoothness(1.0, -1.0), InputError);
}

TEST(Confidence, DeterministicAcrossRunsAndThreadCounts) {
  const SphereField field(0.4, 0.02);
  const PointCloud raw = sphere_points(20000, 0.4, 0.003, 8);
  const auto mesh = icosphere(0.4, 3);
  ConfidenceResult a, b;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    a = assess_confidence(field, mesh, raw, 12.5, small_options(800));
  }
  b = assess_confidence(field, mesh, raw, 12.5, small_options(800));
  ASSERT_EQ(a.iso_points.size(), b.iso_points.size());
  EXPECT_EQ(a.iso_points.positions, b.iso_points.positions);
  EXPECT_EQ(a.iso_points.scalars.get("f"), b.iso_points.scalars.get("f"));
  EXPECT_EQ(a.mesh.vertex_scalars.get("f"), b.mesh.vertex_scalars.get("f"));
  EXPECT_EQ(a.mean_f, b.mean_f);
  auto o = small_options(800);
  o.iso.seed = 99;
  const auto c = assess_confidence(field, mesh, raw, 12.5, o);
  EXPECT_NE(a.iso_points.positions, c.iso_points.positions);
}

TEST(Confidence, EvaluatorReuseEqualsOneOff) {
  const PointCloud raw = sphere_points(20000, 0.4, 0.0, 9);
  const auto mesh = icosphere(0.4, 3);
  const ConfidenceEvaluator ev(raw, small_options(600));
  EXPECT_EQ(ev.raw_size(), raw.size());
  for (double eps : {0.01, 0.03}) {
    const SphereField field(0.4, eps);
    const auto r1 = ev.assess(field, mesh, 25.0);
    const auto r2 = assess_confidence(field, mesh, raw, 25.0, small_options(600));
    EXPECT_EQ(r1.iso_points.scalars.get("f"), r2.iso_points.scalars.get("f"));
    EXPECT_EQ(r1.mean_f, r2.mean_f);
    EXPECT_GE(r1.seconds_total, 0.0);
    EXPECT_GT(r1.reference_smoothness, 24.0);
  }
}

TEST(Confidence, ProgressCanCancel) {
  const PointCloud raw = sphere_points(5000, 0.4, 0.0, 9);
  auto o = small_options(300);
  int calls = 0;
  o.progress = [&calls](std::string_view, double f) {
    ++calls;
    return f < 0.5;
  };
  EXPECT_THROW(assess_confidence(SphereField(0.4, 0.01), icosphere(0.4, 2), raw, 25.0, o), Cancelled);
  EXPECT_GT(calls, 0);
}

TEST(ConfidenceErrors, BadInputIsInputError) {
  const SphereField field(0.4, 0.01);
  const auto mesh = icosphere(0.4, 2);
  const PointCloud raw = sphere_points(500, 0.4, 0.0, 1);
  // K larger than the cloud (K = 100 on 500 points is fine, K = 501 is not).
  EXPECT_NO_THROW(assess_confidence(field, mesh, raw, 25.0, small_options(200)));
  ConfidenceOptions big;
  big.k = 501;
  try {
    ConfidenceEvaluator ev(raw, big);
    ADD_FAILURE() << "K > cloud size must throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("larger than the raw point cloud"), std::string::npos) << e.what();
  }
  // Empty mesh.
  try {
    assess_confidence(field, TriangleMesh{}, raw, 25.0);
    ADD_FAILURE() << "empty mesh must throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("empty"), std::string::npos) << e.what();
  }
  const ConfidenceEvaluator ev(raw);
  EXPECT_THROW(ev.assess(field, TriangleMesh{}, 25.0), InputError);
  EXPECT_THROW(sample_iso_points(field, TriangleMesh{}), InputError);
  // Zero-area mesh.
  TriangleMesh flat;
  flat.vertices = {Vec3::Zero(), Vec3::Zero(), Vec3::Zero()};
  flat.faces = {{0, 1, 2}};
  EXPECT_THROW(ev.assess(field, flat, 25.0), InputError);
  // Out-of-range face index.
  TriangleMesh broken = mesh;
  broken.faces[0][1] = 1'000'000;
  EXPECT_THROW(ev.assess(field, broken, 25.0), InputError);
  // Empty raw cloud, non-finite raw point.
  EXPECT_THROW(ConfidenceEvaluator(PointCloud{}), InputError);
  PointCloud nan = raw;
  nan.positions[3].x() = std::nan("");
  EXPECT_THROW(ConfidenceEvaluator{nan}, InputError);
  // Bad reference gradient and options.
  EXPECT_THROW(ev.assess(field, mesh, 0.0), InputError);
  EXPECT_THROW(ev.assess(field, mesh, std::nan("")), InputError);
  for (auto bad : std::vector<std::function<void(ConfidenceOptions&)>>{
           [](auto& o) { o.k = 0; }, [](auto& o) { o.theta_divisor = 0; }, [](auto& o) { o.phi_divisor = -1; },
           [](auto& o) { o.mesh_neighbours = 0; }, [](auto& o) { o.reference_smoothness = -2; }}) {
    ConfidenceOptions o;
    bad(o);
    EXPECT_THROW(ConfidenceEvaluator(raw, o), InputError);
  }
  for (auto bad : std::vector<std::function<void(IsoPointOptions&)>>{
           [](auto& o) { o.count = 0; }, [](auto& o) { o.spacing = -1; }, [](auto& o) { o.candidate_factor = 0.5; },
           [](auto& o) { o.projection_steps = -1; }, [](auto& o) { o.spacing = 1e-9; }}) {
    IsoPointOptions o;
    bad(o);
    EXPECT_THROW(sample_iso_points(field, mesh, o), InputError);
  }
  // Mismatched spans.
  std::vector<Vec3> p(3, Vec3::Zero()), n(2, Vec3::UnitZ());
  EXPECT_THROW(ev.smoothness(p, n), InputError);
}
