// The confidence map on real screened Poisson reconstructions of the procedural object (issue 6,
// "done when" (a)-(c)): Figures 3/5 (f_g separates missing data), Figure 4 (f_s lower where noisy or
// where detail is under-sampled), Figure 8 (more coverage raises the global confidence).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "autoscan/confidence/assess.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/shapes/procedural.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "fields.hpp"

using namespace autoscan;
using namespace autoscan::confidence;
using namespace autoscan::testing;

namespace {

// The procedural object and a dense uniform sampling of it with outward normals (a scan of every side),
// shared by the tests below.
struct Fixture {
  ProceduralObject object;
  TriangleMesh mesh = object.mesh(100);
  PointCloud full = [this] {
    Rng rng(17);
    PointCloud c = sample_surface(mesh, 150000, rng);
    c.scalars.clear();
    return c;
  }();
};

const Fixture& fixture() {
  static const Fixture f;
  return f;
}

poisson::PoissonOptions poisson_options() {
  poisson::PoissonOptions o;
  o.depth = 7;
  return o;
}

ConfidenceOptions options() {
  ConfidenceOptions o;
  o.iso.count = 4000;
  return o;
}

PointCloud keep_if(const PointCloud& c, const std::function<bool(const Vec3&)>& keep) {
  PointCloud out = c;
  std::vector<std::size_t> idx;
  for (std::size_t i = 0; i < c.size(); ++i)
    if (keep(c.positions[i])) idx.push_back(i);
  out.select(idx);
  return out;
}

// One side missing: the object's +X end (the handle side) was never scanned.
constexpr double kGapX = 0.12;

}  // namespace

TEST(ConfidencePoisson, CompletenessSeparatesTheMissingSide) {
  // (a) Figures 3 and 5: iso-points over the unscanned side have a low f_g.
  const auto& fx = fixture();
  const PointCloud partial = keep_if(fx.full, [](const Vec3& p) { return p.x() < kGapX; });
  const auto a = assess_cloud(partial, poisson_options(), options());
  const auto& fg = a.confidence.iso_points.scalars.get("f_g");
  const auto& pos = a.confidence.iso_points.positions;
  // Ground truth: an iso-point is over missing data when it lies on the unscanned side.
  const auto& h = a.confidence.iso_points.scalars.get("h");
  std::vector<double> scores;
  std::vector<bool> missing;
  for (std::size_t i = 0; i < pos.size(); ++i) {
    if (std::abs(pos[i].x() - kGapX) < 0.03) continue;  // the transition band is neither
    scores.push_back(fg[i]);
    missing.push_back(pos[i].x() > kGapX);
  }
  std::size_t n_missing = std::count(missing.begin(), missing.end(), true);
  ASSERT_GT(n_missing, 100u);
  ASSERT_GT(missing.size() - n_missing, 1000u);
  const double auc = auc_low_is_positive(scores, missing);
  std::printf("f_g AUC (missing side vs rest) = %.3f, mean f_g = %.3f, mean f = %.3f, %zu iso-points\n", auc,
              a.confidence.mean_f_g, a.confidence.mean_f, pos.size());
  EXPECT_GE(auc, 0.9);
  EXPECT_EQ(h.size(), pos.size());
  // The scanned side is close to the reference gradient (absolute mapping: f_g ≈ 1 where complete).
  double scanned = 0;
  int ns = 0;
  for (std::size_t i = 0; i < pos.size(); ++i)
    if (pos[i].x() < kGapX - 0.1) {
      scanned += fg[i];
      ++ns;
    }
  EXPECT_GT(scanned / ns, 0.6);
}

TEST(ConfidencePoisson, SmoothnessIsLowerWhereNoisyOrDetailed) {
  // (b) Figure 4: same point density everywhere; noise on one half lowers f_s there, and the engraved
  // front face (detail the depth-7 surface smooths out) has a lower f_s than the smooth faces.
  const auto& fx = fixture();
  PointCloud noisy = fx.full;
  Rng rng(5);
  for (std::size_t i = 0; i < noisy.size(); ++i)
    if (noisy.positions[i].z() > 0.0) noisy.positions[i] += rng.normal(0.0, 0.004) * noisy.normals[i];
  const auto a = assess_cloud(noisy, poisson_options(), options());
  const auto& fs = a.confidence.iso_points.scalars.get("f_s");
  const auto& pos = a.confidence.iso_points.positions;
  double clean = 0, dirty = 0;
  int nc = 0, nd = 0;
  for (std::size_t i = 0; i < pos.size(); ++i) {
    if (fx.object.region(pos[i]) != ProceduralObject::Region::smooth) continue;
    if (pos[i].z() < -0.05) {
      clean += fs[i];
      ++nc;
    } else if (pos[i].z() > 0.05) {
      dirty += fs[i];
      ++nd;
    }
  }
  ASSERT_GT(nc, 100);
  ASSERT_GT(nd, 100);
  std::printf("mean f_s smooth regions: clean %.3f, noisy %.3f\n", clean / nc, dirty / nd);
  EXPECT_LT(dirty / nd, clean / nc - 0.1);

  // Detail vs smooth on the clean cloud.
  const auto b = assess_cloud(fx.full, poisson_options(), options());
  const auto& fs2 = b.confidence.iso_points.scalars.get("f_s");
  const auto& pos2 = b.confidence.iso_points.positions;
  double smooth = 0, detail = 0;
  int nsm = 0, nde = 0;
  for (std::size_t i = 0; i < pos2.size(); ++i) {
    const auto region = fx.object.region(pos2[i]);
    if (region == ProceduralObject::Region::smooth) {
      smooth += fs2[i];
      ++nsm;
    } else if (region == ProceduralObject::Region::detail) {
      detail += fs2[i];
      ++nde;
    }
  }
  ASSERT_GT(nsm, 100);
  ASSERT_GT(nde, 50);
  std::printf("mean f_s: smooth %.3f, detail %.3f\n", smooth / nsm, detail / nde);
  EXPECT_LT(detail / nde, smooth / nsm);
}

TEST(ConfidencePoisson, CoveringTheGapRaisesGlobalConfidence) {
  // (c) Figure 8: adding the scans that cover the missing side raises the mean f.
  const auto& fx = fixture();
  const PointCloud partial = keep_if(fx.full, [](const Vec3& p) { return p.x() < kGapX; });
  const auto before = assess_cloud(partial, poisson_options(), options());
  const auto after = assess_cloud(fx.full, poisson_options(), options());
  std::printf("global confidence: gap %.4f (f_g %.3f f_s %.3f), covered %.4f (f_g %.3f f_s %.3f)\n",
              before.confidence.mean_f, before.confidence.mean_f_g, before.confidence.mean_f_s, after.confidence.mean_f,
              after.confidence.mean_f_g, after.confidence.mean_f_s);
  EXPECT_GT(after.confidence.mean_f, before.confidence.mean_f + 0.02);
  EXPECT_GT(after.confidence.mean_f_g, before.confidence.mean_f_g);
  // The map is coloured on the Poisson mesh too.
  EXPECT_EQ(after.confidence.mesh.vertices.size(), after.reconstruction.mesh.vertices.size());
  EXPECT_EQ(after.confidence.mesh.vertex_scalars.get("f").size(), after.confidence.mesh.vertices.size());
}

TEST(ConfidencePoisson, BadInput) {
  const auto& fx = fixture();
  PointCloud no_normals = fx.full;
  no_normals.normals.clear();
  try {
    assess_cloud(no_normals);
    ADD_FAILURE() << "a cloud without normals must throw";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no normals"), std::string::npos) << e.what();
  }
  PointCloud few = keep_if(fx.full, [](const Vec3& p) { return p.x() < -0.2 && p.z() < -0.1; });
  few.select({0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11});
  EXPECT_THROW(assess_cloud(few), InputError);  // 12 points < K = 100
  poisson::PoissonResult empty;
  EXPECT_THROW(assess(empty, fx.full), InputError);
}
