#include "autoscan/core/implicit.hpp"

#include "autoscan/core/error.hpp"

namespace autoscan {

void ImplicitField::values(std::span<const Vec3> pts, std::span<double> out) const {
  AUTOSCAN_CHECK(pts.size() == out.size(), "ImplicitField::values: {} points but {} outputs", pts.size(), out.size());
  for (std::size_t i = 0; i < pts.size(); ++i) out[i] = value(pts[i]);
}

void ImplicitField::gradients(std::span<const Vec3> pts, std::span<Vec3> out) const {
  AUTOSCAN_CHECK(pts.size() == out.size(), "ImplicitField::gradients: {} points but {} outputs", pts.size(),
                 out.size());
  for (std::size_t i = 0; i < pts.size(); ++i) out[i] = gradient(pts[i]);
}

}  // namespace autoscan
