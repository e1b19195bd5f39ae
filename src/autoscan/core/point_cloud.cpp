#include "autoscan/core/point_cloud.hpp"

#include <cmath>

#include "autoscan/core/error.hpp"

namespace autoscan {

void PointCloud::validate(const std::string& what) const {
  const auto n = positions.size();
  AUTOSCAN_REQUIRE(normals.empty() || normals.size() == n, "{}: {} normals for {} points", what, normals.size(), n);
  AUTOSCAN_REQUIRE(colors.empty() || colors.size() == n, "{}: {} colours for {} points", what, colors.size(), n);
  for (const auto& [name, col] : scalars.columns())
    AUTOSCAN_REQUIRE(col.size() == n, "{}: scalar '{}' has {} values for {} points", what, name, col.size(), n);
  for (std::size_t i = 0; i < n; ++i) {
    AUTOSCAN_REQUIRE(positions[i].allFinite(), "{}: point {} has a non-finite coordinate", what, i);
    AUTOSCAN_REQUIRE(within_coordinate_range(positions[i]),
                     "{}: point {} has a coordinate beyond ±{:g}, the largest supported magnitude", what, i,
                     kMaxCoordinate);
  }
  for (std::size_t i = 0; i < normals.size(); ++i) {
    AUTOSCAN_REQUIRE(normals[i].allFinite(), "{}: normal {} has a non-finite component", what, i);
    AUTOSCAN_REQUIRE(within_coordinate_range(normals[i]),
                     "{}: normal {} has a component beyond ±{:g}, the largest supported magnitude", what, i,
                     kMaxCoordinate);
  }
}

void PointCloud::select(const std::vector<std::size_t>& keep) {
  auto pick = [&](auto& v) {
    if (v.empty()) return;
    std::remove_reference_t<decltype(v)> out;
    out.reserve(keep.size());
    for (auto i : keep) out.push_back(v.at(i));
    v = std::move(out);
  };
  pick(positions);
  pick(normals);
  pick(colors);
  scalars.select(keep);
}

void PointCloud::append(const PointCloud& other) {
  const auto n = size();
  const auto m = other.size();
  if (has_normals() || other.has_normals()) {
    normals.resize(n, Vec3::Zero());
    if (other.has_normals())
      normals.insert(normals.end(), other.normals.begin(), other.normals.end());
    else
      normals.resize(n + m, Vec3::Zero());
  }
  if (has_colors() || other.has_colors()) {
    colors.resize(n, Rgb{128, 128, 128});
    if (other.has_colors())
      colors.insert(colors.end(), other.colors.begin(), other.colors.end());
    else
      colors.resize(n + m, Rgb{128, 128, 128});
  }
  scalars.append(other.scalars, n, m);
  positions.insert(positions.end(), other.positions.begin(), other.positions.end());
}

}  // namespace autoscan
