#include "autoscan/core/image.hpp"

#include <algorithm>
#include <cmath>

namespace autoscan {

Vec3 Image::sample(double u, double v) const {
  if (empty() || !std::isfinite(u) || !std::isfinite(v)) return Vec3::Zero();
  u -= std::floor(u);
  v -= std::floor(v);
  // Pixel centres at (x + 0.5) / width; v up, rows top first.
  const double fx = u * width - 0.5;
  const double fy = (1.0 - v) * height - 0.5;
  const double x0f = std::floor(fx), y0f = std::floor(fy);
  const double ax = fx - x0f, ay = fy - y0f;
  const int x0 = std::clamp(static_cast<int>(x0f), 0, width - 1);
  const int x1 = std::clamp(static_cast<int>(x0f) + 1, 0, width - 1);
  const int y0 = std::clamp(static_cast<int>(y0f), 0, height - 1);
  const int y1 = std::clamp(static_cast<int>(y0f) + 1, 0, height - 1);
  auto px = [&](int x, int y) {
    const Rgb& c = at(x, y);
    return Vec3(c[0], c[1], c[2]);
  };
  return (1 - ay) * ((1 - ax) * px(x0, y0) + ax * px(x1, y0)) + ay * ((1 - ax) * px(x0, y1) + ax * px(x1, y1));
}

}  // namespace autoscan
