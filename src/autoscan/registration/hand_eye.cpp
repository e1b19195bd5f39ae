#include "autoscan/registration/hand_eye.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numbers>
#include <vector>

#include "autoscan/core/error.hpp"
#include "autoscan/core/pose.hpp"

namespace autoscan::registration {

namespace {
constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// Pairs whose motion turns less than this carry no rotation axis (and a translation equation of
// rank 0): left out of both steps.
constexpr double kMinAngle = 1e-3;  // radians
// Near a half turn the rotation vector's axis flips sign under the least noise: such pairs are left
// out too.
constexpr double kMaxAngle = 0.8 * std::numbers::pi;

Vec3 log_so3(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}
}  // namespace

HandEyeEstimate estimate_hand_eye(std::span<const Eigen::Isometry3d> commanded,
                                  std::span<const Eigen::Isometry3d> registered) {
  AUTOSCAN_REQUIRE(commanded.size() == registered.size(), "hand-eye: {} commanded poses for {} registered ones",
                   commanded.size(), registered.size());
  AUTOSCAN_REQUIRE(commanded.size() >= 2, "hand-eye: {} scans; the motion between two is needed at least",
                   commanded.size());
  const std::size_t n = commanded.size();
  struct Motion {
    Eigen::Isometry3d a, b;
    Vec3 alpha, beta;
  };
  std::vector<Motion> motions;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      Motion m{commanded[i].inverse() * commanded[j], registered[i].inverse() * registered[j], {}, {}};
      m.alpha = log_so3(m.a.linear());
      m.beta = log_so3(m.b.linear());
      const double a = m.alpha.norm(), b = m.beta.norm();
      if (a < kMinAngle || b < kMinAngle || a > kMaxAngle || b > kMaxAngle) continue;
      motions.push_back(m);
    }
  HandEyeEstimate e;
  e.scans = static_cast<int>(n);
  if (motions.empty()) return e;
  // Rotation: R β_k ≈ α_k (A = H B H⁻¹ turns about R_H's image of B's axis), Kabsch without centring.
  Mat3 M = Mat3::Zero();
  Mat3 info_r = Mat3::Zero();  // Σ (|β|² I − β βᵀ): the rotation's information, up to the noise
  for (const auto& m : motions) {
    M += m.alpha * m.beta.transpose();
    info_r += m.beta.squaredNorm() * Mat3::Identity() - m.beta * m.beta.transpose();
  }
  const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 D = Mat3::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  const Mat3 R = svd.matrixU() * D * svd.matrixV().transpose();
  // Translation: (R_A − I) t = R t_B − t_A.
  Mat3 JtJ = Mat3::Zero();
  Vec3 Jtr = Vec3::Zero();
  for (const auto& m : motions) {
    const Mat3 J = m.a.linear() - Mat3::Identity();
    JtJ += J.transpose() * J;
    Jtr += J.transpose() * (R * m.b.translation() - m.a.translation());
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig_t(JtJ);
  const Eigen::SelfAdjointEigenSolver<Mat3> eig_r(info_r);
  const double lt = eig_t.eigenvalues()(0), lr = eig_r.eigenvalues()(0);
  // Observable: the weakest direction holds a useful share of the strongest (two axes at least).
  e.observable = lt > 1e-6 * eig_t.eigenvalues()(2) && lr > 1e-6 * eig_r.eigenvalues()(2) && lt > 0 && lr > 0;
  const Vec3 t = e.observable ? Vec3(JtJ.ldlt().solve(Jtr)) : Vec3::Zero();
  e.offset.linear() = R;
  e.offset.translation() = t;
  e.translation = t;
  e.rotation_deg = log_so3(R) * kRadToDeg;  // (offset == rigid_from_vectors(translation, rotation_deg))
  // Residuals and standard errors.
  double sr = 0.0, st = 0.0;
  for (const auto& m : motions) {
    sr += (R * m.beta - m.alpha).squaredNorm();
    st += ((m.a.linear() - Mat3::Identity()) * t - (R * m.b.translation() - m.a.translation())).squaredNorm();
  }
  const double k = double(motions.size());
  e.residual_rotation_deg = std::sqrt(sr / k) * kRadToDeg;
  e.residual_translation = std::sqrt(st / k);
  if (e.observable && motions.size() > 1) {
    const double dof = std::max(1.0, 3.0 * k - 3.0);
    const double scale = k / std::max(1.0, double(n) - 1.0);  // n − 1 independent motions
    e.rotation_se_deg = std::sqrt(sr / dof / lr * scale) * kRadToDeg;
    e.translation_se = std::sqrt(st / dof / lt * scale);
  }
  // (floors: with exact poses the residuals, and so the errors, are 0; a round-off offset is not one)
  e.significant = e.observable && n >= 4 &&
                  (t.norm() > std::max(3.0 * e.translation_se, 1e-9) ||
                   e.rotation_deg.norm() > std::max(3.0 * e.rotation_se_deg, 1e-6));
  return e;
}

nlohmann::json to_json(const HandEyeEstimate& e) {
  return {{"scans", e.scans},
          {"translation", {e.translation.x(), e.translation.y(), e.translation.z()}},
          {"rotation_deg", {e.rotation_deg.x(), e.rotation_deg.y(), e.rotation_deg.z()}},
          {"translation_se", e.translation_se},
          {"rotation_se_deg", e.rotation_se_deg},
          {"residual_translation", e.residual_translation},
          {"residual_rotation_deg", e.residual_rotation_deg},
          {"observable", e.observable},
          {"significant", e.significant}};
}

HandEyeEstimate hand_eye_from_json(const nlohmann::json& j, const std::string& what) {
  AUTOSCAN_REQUIRE(j.is_object(), "{}: expected an object", what);
  auto vec = [&](const char* key) {
    AUTOSCAN_REQUIRE(j.contains(key) && j.at(key).is_array() && j.at(key).size() == 3 &&
                         std::all_of(j.at(key).begin(), j.at(key).end(), [](const auto& x) { return x.is_number(); }),
                     "{}.{}: expected an array of 3 numbers", what, key);
    return Vec3(j.at(key)[0].get<double>(), j.at(key)[1].get<double>(), j.at(key)[2].get<double>());
  };
  auto num = [&](const char* key) {
    AUTOSCAN_REQUIRE(j.contains(key) && j.at(key).is_number(), "{}.{}: expected a number", what, key);
    return j.at(key).get<double>();
  };
  auto flag = [&](const char* key) {
    AUTOSCAN_REQUIRE(j.contains(key) && j.at(key).is_boolean(), "{}.{}: expected true or false", what, key);
    return j.at(key).get<bool>();
  };
  HandEyeEstimate e;
  AUTOSCAN_REQUIRE(j.contains("scans") && j.at("scans").is_number_integer(), "{}.scans: expected an integer", what);
  e.scans = j.at("scans").get<int>();
  e.translation = vec("translation");
  e.rotation_deg = vec("rotation_deg");
  e.offset = rigid_from_vectors(e.translation, e.rotation_deg);
  e.translation_se = num("translation_se");
  e.rotation_se_deg = num("rotation_se_deg");
  e.residual_translation = num("residual_translation");
  e.residual_rotation_deg = num("residual_rotation_deg");
  e.observable = flag("observable");
  e.significant = flag("significant");
  return e;
}

}  // namespace autoscan::registration
