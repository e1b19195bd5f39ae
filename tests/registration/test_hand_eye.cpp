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
  // A ring at one height turns about one axis: the translation along it is unobservable.
  std::vector<Eigen::Isometry3d> flat, flat_reg;
  for (int i = 0; i < 8; ++i) {
    const double a = 2.0 * std::numbers::pi * i / 8;
    flat.push_back(Pose::look_at(Vec3(1.2 * std::cos(a), 1.2 * std::sin(a), 0.0), Vec3::Zero()).world_from_camera());
    flat_reg.push_back(W * flat.back() * H);
  }
  const auto f = estimate_hand_eye(flat, flat_reg);
  EXPECT_FALSE(f.observable);
  EXPECT_FALSE(f.significant);
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
