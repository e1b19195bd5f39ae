#pragma once
// A point cloud: positions, optional normals and colours, and named per-point scalars.
// Contract: normals, when present, have positions.size() entries (unit length unless a stage says
// otherwise); colours likewise; every scalar column has positions.size() values.
// Conventional scalar names: "scan_id", "sensor_x/y/z" (the scanner position the point was seen
// from, used to orient normals), "f", "f_g", "f_s" (confidence, paper Eq. 1-3).
#include <string>
#include <vector>

#include "autoscan/core/attributes.hpp"
#include "autoscan/core/types.hpp"

namespace autoscan {

struct PointCloud {
  std::vector<Vec3> positions;
  std::vector<Vec3> normals;  ///< empty or one per point
  std::vector<Rgb> colors;    ///< empty or one per point
  ScalarAttributes scalars;   ///< named per-point values

  std::size_t size() const { return positions.size(); }
  bool empty() const { return positions.empty(); }
  bool has_normals() const { return !normals.empty(); }
  bool has_colors() const { return !colors.empty(); }
  AABB bounds() const { return AABB::of(positions); }

  /// Throws InputError (prefixed by `what`, e.g. a file name) if sizes disagree or any coordinate or
  /// normal is NaN/Inf.
  void validate(const std::string& what = "point cloud") const;
  /// Keeps the listed points, in that order, with all their attributes.
  void select(const std::vector<std::size_t>& keep);
  /// Appends `other`; attributes present on one side only are filled (normals with zero, colours
  /// with grey, scalars with 0).
  void append(const PointCloud& other);
};

}  // namespace autoscan
