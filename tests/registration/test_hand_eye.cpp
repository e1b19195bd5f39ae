// The hand-eye offset from commanded and registered poses (registration/hand_eye.hpp).
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <vector>

#include "autoscan/core/error.hpp"
#include "autoscan/core/pose.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/registration/hand_eye.hpp"

using namespace autoscan;
using namespace autoscan::registration;

namespace {
constexpr double kDeg = std::numbers::pi / 180.0;

Eigen::Isometry3d offset(const Vec3& t, const Vec3& rot_deg) { return rigid_from_vectors(t, rot_deg); }

// Views around an object, as a robot commands them.
std::vector<Eigen::Isometry3d> ring(int n) {
  std::vector<Eigen::Isometry3d> out;
  for (int i = 0; i < n; ++i) {
    const double a = 2.0 * std::numbers::pi * i / n;
    const double el = (-20.0 + 25.0 * (i % 4)) * kDeg;  // four heights: motions about two axes at least
    out.push_back(
        Pose::look_at(1.2 * Vec3(std::cos(el) * std::cos(a), std::cos(el) * std::sin(a), std::sin(el)), Vec3::Zero())
            .world_from_camera());
  }
  return out;
}
}  // namespace

TEST(HandEye, AnOffsetSharedByEveryScanIsRecoveredExactly) {
  const auto H = offset(Vec3(0.005, -0.002, 0.003), Vec3(0.5, 1.0, -1.2));  // 5 mm, 1.6 degrees
  const auto commanded = ring(12);
  // The model's frame is not the robot's (a registration fixes its first scan where it was reported).
  const auto W = offset(Vec3(0.3, -0.1, 0.2), Vec3(10.0, -5.0, 30.0));
  std::vector<Eigen::Isometry3d> registered;
  for (const auto& c : commanded) registered.push_back(W * c * H);
  const auto e = estimate_hand_eye(commanded, registered);
  EXPECT_EQ(e.scans, 12);
  EXPECT_LT((e.offset.matrix() - H.matrix()).norm(), 1e-9);
  EXPECT_LT((e.translation - Vec3(0.005, -0.002, 0.003)).norm(), 1e-9);
  EXPECT_LT((e.rotation_deg - Vec3(0.5, 1.0, -1.2)).norm(), 1e-6);
  EXPECT_LT(e.translation_se, 1e-9);
  EXPECT_LT(e.rotation_se_deg, 1e-6);
  EXPECT_TRUE(e.observable);
  EXPECT_TRUE(e.significant);
  // The JSON round trip rebuilds the offset; a malformed record names its field.
  const auto back = hand_eye_from_json(to_json(e), "hand_eye");
  EXPECT_LT((back.offset.matrix() - e.offset.matrix()).norm(), 1e-9);
  EXPECT_EQ(back.significant, e.significant);
  auto bad = to_json(e);
  bad["translation"] = {1, 2};
  EXPECT_THROW(hand_eye_from_json(bad, "hand_eye"), InputError);
  EXPECT_EQ(e.rotation_rank, 3);
  EXPECT_EQ(e.translation_rank, 3);
}

TEST(HandEye, OnAOneAxisRingThePartTheScansSeeIsRecoveredAndTheRestIsAGauge) {
  // A ring at one height (a turntable) turns about one axis: H is known up to a turn about it and a
  // shift along it, which move the whole model rigidly (registration/hand_eye.hpp).
  const auto H = offset(Vec3(0.005, -0.002, 0.003), Vec3(0.5, 1.0, -1.2));
  const auto W = offset(Vec3(0.3, -0.1, 0.2), Vec3(10.0, -5.0, 30.0));
  std::vector<Eigen::Isometry3d> flat, flat_reg;
  for (int i = 0; i < 15; ++i) {
    const double a = 2.0 * std::numbers::pi * i / 15;
    flat.push_back(Pose::look_at(Vec3(1.2 * std::cos(a), 1.2 * std::sin(a), 0.1), Vec3::Zero()).world_from_camera());
    flat_reg.push_back(W * flat.back() * H);
  }
  const auto f = estimate_hand_eye(flat, flat_reg);
  EXPECT_FALSE(f.observable);
  EXPECT_EQ(f.rotation_rank, 2);
  EXPECT_EQ(f.translation_rank, 2);
  EXPECT_TRUE(f.significant);
  EXPECT_LT(f.translation_se, 1e-9);
  // Every scan corrected by the estimate, C_i Ĥ, is where the truth W C_i H is, up to one rigid
  // motion Z for all of them: C_i Ĥ (W C_i H)⁻¹ = Z.
  const Eigen::Isometry3d Z0 = flat[0] * f.offset * flat_reg[0].inverse();
  for (std::size_t i = 1; i < flat.size(); ++i)
    EXPECT_LT((flat[i] * f.offset * flat_reg[i].inverse()).matrix().isApprox(Z0.matrix(), 1e-9) ? 0.0 : 1.0, 0.5)
        << "scan " << i;
  // The estimate is the gauge's smallest: its rotation has no part about the ring's axis (z in the
  // world, the camera's −y here), its translation none along it.
  const Vec3 axis = flat[0].linear().transpose() * Vec3::UnitZ();
  EXPECT_LT(std::abs(f.rotation_deg.dot(axis)), 1e-6);
  EXPECT_LT(std::abs(f.translation.dot(axis)), 1e-9);
  // The JSON carries the ranks; a record written before them reads as both 3 or both 0.
  const auto back = hand_eye_from_json(to_json(f), "hand_eye");
  EXPECT_EQ(back.rotation_rank, 2);
  auto old = to_json(f);
  old.erase("rotation_rank");
  old.erase("translation_rank");
  EXPECT_EQ(hand_eye_from_json(old, "hand_eye").translation_rank, 0);
  old["rotation_rank"] = 4;
  EXPECT_THROW(hand_eye_from_json(old, "hand_eye"), InputError);
  // With 1 mm and 0.2 degrees at random per scan, over 50 draws: the seen part's error against the
  // exact estimate's (the same gauge) is about its standard error (measured: RMS error / RMS standard
  // error 1.55 for the translation, 1.36 for the rotation; the errors are norms over the 2 seen
  // directions, the standard errors the worst direction's), and every draw finds the offset.
  double err_t = 0, err_r = 0, se_t = 0, se_r = 0;
  int found = 0;
  for (int seed = 1; seed <= 50; ++seed) {
    Rng rng(static_cast<std::uint64_t>(seed));
    std::vector<Eigen::Isometry3d> noisy;
    for (const auto& r : flat_reg)
      noisy.push_back(r * offset(Vec3(rng.normal(0, 0.001), rng.normal(0, 0.001), rng.normal(0, 0.001)),
                                 Vec3(rng.normal(0, 0.2), rng.normal(0, 0.2), rng.normal(0, 0.2))));
    const auto g = estimate_hand_eye(flat, noisy);
    EXPECT_EQ(g.rotation_rank, 2);
    EXPECT_EQ(g.translation_rank, 2);
    found += g.significant ? 1 : 0;
    err_t += (g.translation - f.translation).squaredNorm();
    err_r += (g.rotation_deg - f.rotation_deg).squaredNorm();
    se_t += g.translation_se * g.translation_se;
    se_r += g.rotation_se_deg * g.rotation_se_deg;
  }
  EXPECT_EQ(found, 50);
  EXPECT_LT(std::sqrt(err_t / se_t), 2.0);
  EXPECT_LT(std::sqrt(err_r / se_r), 2.0);
  EXPECT_LT(std::sqrt(se_t / 50), 0.0015);  // about 1 mm (0.2 degrees at 1.2 m)
}

TEST(HandEye, ARandomErrorAloneIsNotSignificantAndTheSpreadIsItsStandardError) {
  Rng rng(3);
  const auto commanded = ring(40);
  const auto H = offset(Vec3(0.004, 0.0, 0.0), Vec3(0.0, 0.0, 1.5));
  std::vector<Eigen::Isometry3d> with, without;
  for (const auto& c : commanded) {
    // 1 mm and 0.2 degrees at random per scan, in the scanner's frame.
    const auto noise = offset(Vec3(rng.normal(0, 0.001), rng.normal(0, 0.001), rng.normal(0, 0.001)),
                              Vec3(rng.normal(0, 0.2), rng.normal(0, 0.2), rng.normal(0, 0.2)));
    with.push_back(c * H * noise);  // (the model's frame the robot's here: W = I)
    without.push_back(c * noise);
  }
  const auto e = estimate_hand_eye(commanded, with);
  EXPECT_TRUE(e.significant);
  // Within 3 standard errors of the injected offset. The random rotation (0.2 degrees) moves the
  // motions' translations by its lever arm (1.2 × 0.0035 = 4 mm): the translation's standard error
  // is about 1 mm here, the rotation's 0.06 degrees (measured).
  EXPECT_LT((e.translation - Vec3(0.004, 0, 0)).norm(), 3.0 * e.translation_se + 1e-12);
  EXPECT_GT(e.translation_se, 1e-5);
  EXPECT_LT(e.translation_se, 0.002);
  EXPECT_LT(e.rotation_se_deg, 0.15);
  EXPECT_LT(std::abs(e.rotation_deg.z() - 1.5), 3.0 * e.rotation_se_deg);
  // Exact poses: nothing, and not significant (the errors are 0 too).
  EXPECT_FALSE(estimate_hand_eye(commanded, commanded).significant);
  const auto z = estimate_hand_eye(commanded, without);
  EXPECT_FALSE(z.significant) << z.translation.transpose() << " ± " << z.translation_se;
  EXPECT_THROW(estimate_hand_eye(commanded, std::span<const Eigen::Isometry3d>(with).first(3)), InputError);
  EXPECT_THROW(estimate_hand_eye(std::span<const Eigen::Isometry3d>(commanded).first(1),
                                 std::span<const Eigen::Isometry3d>(with).first(1)),
               InputError);
}
