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
// A direction of the rotation (or translation) is observable when its information is at least this
// share of the strongest direction's: motion axes spread by about √0.01 = 0.1 rad (6 degrees). A ring
// whose axes differ by the registration's noise alone (tenths of a degree) has one axis.
constexpr double kMinInformationShare = 0.01;

int observable_rank(const Eigen::SelfAdjointEigenSolver<Mat3>& eig) {
  const double top = eig.eigenvalues()(2);
  if (!(top > 0.0)) return 0;
  int r = 0;
  for (int c = 0; c < 3; ++c) r += eig.eigenvalues()(c) >= kMinInformationShare * top ? 1 : 0;
  return r;
}

Vec3 log_so3(const Mat3& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}
// The pseudo-inverse over the `rank` strongest directions.
Mat3 pseudo_inverse(const Eigen::SelfAdjointEigenSolver<Mat3>& eig, int rank) {
  Mat3 out = Mat3::Zero();
  for (int c = 3 - rank; c < 3; ++c)
    out += eig.eigenvectors().col(c) * eig.eigenvectors().col(c).transpose() / eig.eigenvalues()(c);
  return out;
}

Mat3 skew(const Vec3& v) {
  Mat3 m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
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
  const Eigen::SelfAdjointEigenSolver<Mat3> eig_r(info_r);
  e.rotation_rank = observable_rank(eig_r);
  const Eigen::JacobiSVD<Mat3> svd(M, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Mat3 R;
  if (e.rotation_rank == 3) {
    Mat3 D = Mat3::Identity();
    D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
    R = svd.matrixU() * D * svd.matrixV().transpose();
  } else {
    // One axis (M ≈ s u vᵀ, α ∥ u, β ∥ v): the turn about it is a gauge (see the header); the
    // smallest rotation taking v to u fixes it.
    R = Eigen::Quaterniond::FromTwoVectors(Vec3(svd.matrixV().col(0)), Vec3(svd.matrixU().col(0))).toRotationMatrix();
  }
  // Translation: (R_A − I) t = R t_B − t_A, in least squares; along an unobservable direction 0
  // (the minimum-norm solution).
  Mat3 JtJ = Mat3::Zero();
  Vec3 Jtr = Vec3::Zero();
  for (const auto& m : motions) {
    const Mat3 J = m.a.linear() - Mat3::Identity();
    JtJ += J.transpose() * J;
    Jtr += J.transpose() * (R * m.b.translation() - m.a.translation());
  }
  const Eigen::SelfAdjointEigenSolver<Mat3> eig_t(JtJ);
  e.translation_rank = observable_rank(eig_t);
  e.observable = e.rotation_rank == 3 && e.translation_rank == 3;
  Vec3 t = Vec3::Zero();
  for (int c = 3 - e.translation_rank; c < 3; ++c)
    t += eig_t.eigenvectors().col(c) * (eig_t.eigenvectors().col(c).dot(Jtr) / eig_t.eigenvalues()(c));
  // The weakest observable direction of each (the standard errors are the worst direction's).
  const double lt = e.translation_rank > 0 ? eig_t.eigenvalues()(3 - e.translation_rank) : 0.0;
  const double lr = e.rotation_rank > 0 ? eig_r.eigenvalues()(3 - e.rotation_rank) : 0.0;
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
  if (lt > 0.0 && lr > 0.0 && motions.size() > 1) {
    const double dof = std::max(1.0, 3.0 * k - 3.0);
    const double scale = k / std::max(1.0, double(n) - 1.0);  // n − 1 independent motions
    const double var_r = sr / dof * scale, var_t = st / dof * scale;
    e.rotation_se_deg = std::sqrt(var_r / lr) * kRadToDeg;
    // The translation's covariance: its own least squares, plus the rotation's error carried over
    // through R t_B (a rotation error δ moves the right side by −[R t_B]× δ: with motions a metre
    // long, 0.05 degrees are a millimetre).
    const Mat3 Jpinv = pseudo_inverse(eig_t, e.translation_rank);
    Mat3 G = Mat3::Zero();
    for (const auto& m : motions) G += (m.a.linear() - Mat3::Identity()).transpose() * skew(R * m.b.translation());
    G = Jpinv * G;
    const Mat3 cov_t = var_t * Jpinv + var_r * G * pseudo_inverse(eig_r, e.rotation_rank) * G.transpose();
    e.translation_se = std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Mat3>(cov_t).eigenvalues()(2)));
  }
  // (floors: with exact poses the residuals, and so the errors, are 0; a round-off offset is not one)
  e.significant = e.rotation_rank >= 2 && e.translation_rank >= 2 && n >= 4 &&
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
          {"rotation_rank", e.rotation_rank},
          {"translation_rank", e.translation_rank},
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
  // (absent before the ring's partial estimate: an observable estimate had both ranks 3, else 0)
  auto rank = [&](const char* key) {
    if (!j.contains(key)) return e.observable ? 3 : 0;
    AUTOSCAN_REQUIRE(j.at(key).is_number_integer() && j.at(key).get<int>() >= 0 && j.at(key).get<int>() <= 3,
                     "{}.{}: expected an integer from 0 to 3", what, key);
    return j.at(key).get<int>();
  };
  e.rotation_rank = rank("rotation_rank");
  e.translation_rank = rank("translation_rank");
  return e;
}

}  // namespace autoscan::registration
