#include "autoscan/io/colormap.hpp"

#include <algorithm>
#include <array>
#include <cmath>

namespace autoscan::io {
namespace {

std::uint8_t channel(double v) { return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0))); }

template <std::size_t N>
Rgb piecewise(double t, const std::array<std::array<double, 3>, N>& stops) {
  if (std::isnan(t)) return {128, 128, 128};
  t = std::clamp(t, 0.0, 1.0) * static_cast<double>(N - 1);
  const auto i = std::min(static_cast<std::size_t>(t), N - 2);
  const double u = t - static_cast<double>(i);
  Rgb c;
  for (int k = 0; k < 3; ++k) c[k] = channel((1.0 - u) * stops[i][k] + u * stops[i + 1][k]);
  return c;
}

}  // namespace

Rgb colormap(double t) {
  static constexpr std::array<std::array<double, 3>, 5> stops = {
      {{0, 0, 255}, {0, 255, 255}, {0, 255, 0}, {255, 255, 0}, {255, 0, 0}}};
  return piecewise(t, stops);
}

Rgb colormap_diverging(double t) {
  static constexpr std::array<std::array<double, 3>, 3> stops = {{{59, 76, 192}, {255, 255, 255}, {180, 4, 38}}};
  return piecewise(t, stops);
}

}  // namespace autoscan::io
