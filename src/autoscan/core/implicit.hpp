#pragma once
// An evaluable implicit field, the contract between the Poisson stage and the stages that assess
// and use its surface (confidence, nbv). The screened Poisson solver returns an object implementing
// it; tests use analytic fields. Convention (as PoissonRecon and the paper's Figure 3): the field is
// larger inside the solid than outside, so the gradient at the iso-surface points inward and the
// outward unit normal is -gradient/|gradient|.
// Thread-safety: all const member functions may be called concurrently.
#include <span>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan {

class ImplicitField {
 public:
  virtual ~ImplicitField() = default;
  virtual double value(const Vec3& p) const = 0;
  virtual Vec3 gradient(const Vec3& p) const = 0;
  /// The level at which the surface is extracted.
  virtual double iso_value() const = 0;
  /// True when p is inside the solid (value above the iso-value).
  bool inside(const Vec3& p) const { return value(p) > iso_value(); }
  /// Batch queries; the default loops, implementations may parallelise. out.size() == pts.size().
  virtual void values(std::span<const Vec3> pts, std::span<double> out) const;
  virtual void gradients(std::span<const Vec3> pts, std::span<Vec3> out) const;
};

}  // namespace autoscan
