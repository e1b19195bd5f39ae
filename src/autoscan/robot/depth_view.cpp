#include "autoscan/robot/depth_view.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <optional>

#include "autoscan/core/error.hpp"

namespace autoscan::robot {

void PinholeCamera::validate(const std::string& what) const {
  AUTOSCAN_REQUIRE(width > 0 && height > 0, "{}: the image size must be positive (got {} x {})", what, width, height);
  AUTOSCAN_REQUIRE(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0,
                   "{}: the focal lengths fx, fy must be positive numbers (got {}, {}; is CameraInfo's K set?)", what,
                   fx, fy);
  AUTOSCAN_REQUIRE(std::isfinite(cx) && std::isfinite(cy), "{}: the principal point cx, cy must be finite", what);
}

namespace {

// Depth of pixel (u, v) in metres, or nullopt for no measurement (REP 118) or one outside the range.
struct DepthReader {
  const DepthImage& image;
  const DepthToPointsOptions& options;
  std::optional<double> operator()(int u, int v) const {
    const auto i =
        static_cast<std::size_t>(v) * static_cast<std::size_t>(image.camera.width) + static_cast<std::size_t>(u);
    double z;
    if (!image.millimetres_data.empty()) {
      const std::uint16_t mm = image.millimetres_data[i];
      if (mm == 0) return std::nullopt;
      z = 0.001 * mm;
    } else {
      const float m = image.metres_data[i];
      if (!std::isfinite(m) || m <= 0.0f) return std::nullopt;
      z = m;
    }
    if (z < options.min_depth || z > options.max_depth) return std::nullopt;
    return z;
  }
};

}  // namespace

PointCloud depth_to_points(const DepthImage& image, const DepthToPointsOptions& options, const std::string& what) {
  const PinholeCamera& c = image.camera;
  c.validate(what + ": camera");
  const std::size_t n = static_cast<std::size_t>(c.width) * static_cast<std::size_t>(c.height);
  const bool mm = !image.millimetres_data.empty(), m = !image.metres_data.empty();
  AUTOSCAN_REQUIRE(mm != m, "{}: expected the data of one encoding (16UC1 millimetres or 32FC1 metres), got {}", what,
                   mm ? "both" : "none");
  const std::size_t got = mm ? image.millimetres_data.size() : image.metres_data.size();
  AUTOSCAN_REQUIRE(got == n, "{}: {} values for a {} x {} image (expected {})", what, got, c.width, c.height, n);
  AUTOSCAN_REQUIRE(options.stride >= 1, "{}: stride must be at least 1 (got {})", what, options.stride);
  AUTOSCAN_REQUIRE(options.min_depth >= 0 && options.min_depth < options.max_depth,
                   "{}: the depth range [{}, {}] is empty or negative", what, options.min_depth, options.max_depth);
  AUTOSCAN_REQUIRE(options.normal_max_step > 0, "{}: normal_max_step must be positive", what);

  const DepthReader depth{image, options};
  auto point = [&](int u, int v) -> std::optional<Vec3> {
    if (u < 0 || v < 0 || u >= c.width || v >= c.height) return std::nullopt;
    const auto z = depth(u, v);
    if (!z) return std::nullopt;
    return c.unproject(u, v, *z);
  };
  PointCloud out;
  for (int v = 0; v < c.height; v += options.stride)
    for (int u = 0; u < c.width; u += options.stride) {
      const auto p = point(u, v);
      if (!p) continue;
      if (!options.normals) {
        out.positions.push_back(*p);
        continue;
      }
      // Central differences where both neighbours exist, one-sided otherwise; a neighbour across a
      // depth step (a silhouette) does not count.
      const double step = options.normal_max_step * p->z();
      auto near = [&](int du, int dv) -> std::optional<Vec3> {
        const auto q = point(u + du, v + dv);
        if (q && std::abs(q->z() - p->z()) <= step) return q;
        return std::nullopt;
      };
      auto tangent = [&](int du, int dv) -> std::optional<Vec3> {
        const auto a = near(du, dv), b = near(-du, -dv);
        if (a && b) return Vec3(*a - *b);
        if (a) return Vec3(*a - *p);
        if (b) return Vec3(*p - *b);
        return std::nullopt;
      };
      const auto tu = tangent(1, 0), tv = tangent(0, 1);
      if (!tu || !tv) continue;
      Vec3 nrm = tu->cross(*tv);
      if (!(nrm.norm() > 0)) continue;
      nrm.normalize();
      if (nrm.dot(*p) > 0) nrm = -nrm;  // towards the camera
      out.positions.push_back(*p);
      out.normals.push_back(nrm);
    }
  return out;
}

}  // namespace autoscan::robot
