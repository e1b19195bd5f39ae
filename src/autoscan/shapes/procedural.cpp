#include "autoscan/shapes/procedural.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "autoscan/core/error.hpp"
#include "autoscan/shapes/implicit_mesher.hpp"

namespace autoscan {
namespace {

double smoothstep(double e0, double e1, double x) {
  const double t = std::clamp((x - e0) / (e1 - e0), 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Polynomial smooth minimum; its gradient is a convex combination of the arguments' gradients, so
// it keeps 1-Lipschitz functions 1-Lipschitz.
double smin(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

// Exact signed distance to the box of half extents `half` (corners rounded by r) centred at c.
double rounded_box(const Vec3& p, const Vec3& c, const Vec3& half, double r) {
  const Vec3 q = (p - c).cwiseAbs() - (half - Vec3::Constant(r));
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0) - r;
}

constexpr double kWindowMargin = 0.03;    // fade-in width of the engraving at the face's border
constexpr double kWindowInset = 0.06;     // distance of the engraved window from the body's edges
constexpr double kDepthFadeStart = 0.03;  // engraving applies fully within this depth below the face
constexpr double kDepthFadeWidth = 0.05;  // ... and fades out over this width

}  // namespace

ProceduralObject::ProceduralObject() : ProceduralObject(Params{}) {}

ProceduralObject::ProceduralObject(const Params& params) : params_(params) {
  const auto& P = params_;
  AUTOSCAN_REQUIRE((P.body_half.array() > P.body_rounding).all() && P.body_rounding > 0,
                   "ProceduralObject: body half extents must exceed the rounding radius");
  AUTOSCAN_REQUIRE(P.fin_thickness > 0 && P.fin_radius > 0 && P.handle_minor > 0 && P.handle_major > P.handle_minor,
                   "ProceduralObject: invalid fin or handle size");
  AUTOSCAN_REQUIRE(P.hood_wall > 0 && P.hood_depth > P.hood_wall && P.hood_top - P.hood_bottom > P.hood_wall &&
                       P.hood_half_width > P.hood_wall,
                   "ProceduralObject: invalid hood size");
  design_box_.extend(Vec3(-P.body_half.x() - P.hood_depth, -P.body_half.y(), -P.body_half.z()));
  design_box_.extend(Vec3(std::max(P.body_half.x(), P.handle_center_x + P.handle_major + P.handle_minor),
                          P.body_half.y(), std::max(P.body_half.z() + P.fin_radius, P.hood_top)));
  design_box_.extend(Vec3(P.handle_center_x, P.handle_minor, P.handle_center_z - P.handle_major - P.handle_minor));
  to_world_.scale = 1.0 / design_box_.diagonal();
  to_world_.translation = -to_world_.scale * design_box_.center();

  // Lipschitz bound of the engraved body: 1 + max |grad(depth · window)|, measured on a dense grid
  // over the face (about 20 samples per finest wavelength) with a 25 % margin, plus the bound of
  // the depth fade.
  const double y_face = -P.body_half.y();
  const double wx = P.body_half.x() - kWindowInset, wz = P.body_half.z() - kWindowInset;
  const int N = 300;
  const double step = 1e-6;
  double g = 0;
  for (int a = 0; a <= N; ++a)
    for (int b = 0; b <= N; ++b) {
      const Vec3 q(-wx + 2 * wx * a / N, y_face, -wz + 2 * wz * b / N);
      const auto dw = [&](const Vec3& d) { return engraving(q + d) - engraving(q - d); };
      const double gx = dw(Vec3(step, 0, 0)) / (2 * step), gz = dw(Vec3(0, 0, step)) / (2 * step);
      g = std::max(g, std::hypot(gx, gz));
    }
  body_lipschitz_ = 1.0 + 1.25 * g + P.detail_depth_max * 1.5 / kDepthFadeWidth;
}

AABB ProceduralObject::bounds() const {
  AABB b;
  b.extend(to_world_.apply(design_box_.min));
  b.extend(to_world_.apply(design_box_.max));
  return b;
}

double ProceduralObject::detail_window(const Vec3& q) const {
  const auto& P = params_;
  const double wx = P.body_half.x() - kWindowInset, wz = P.body_half.z() - kWindowInset;
  const double y0 = -P.body_half.y() + kDepthFadeStart;
  return smoothstep(0, kWindowMargin, wx - std::abs(q.x())) * smoothstep(0, kWindowMargin, wz - std::abs(q.z())) *
         smoothstep(y0 + kDepthFadeWidth, y0, q.y());
}

double ProceduralObject::engraving(const Vec3& q) const {
  const auto& P = params_;
  const double wx = P.body_half.x() - kWindowInset;
  const double w = detail_window(q);
  if (w <= 0) return 0;
  const double L = 2 * wx;
  const double u = std::clamp((q.x() + wx) / L, 0.0, 1.0);
  // Wavelength decreasing geometrically from coarse to fine along +X; the phase is its integral
  // (a chirp), so the bumps stay continuous while their frequency grows.
  const double r = P.detail_wavelength_fine / P.detail_wavelength_coarse;
  const double lambda = P.detail_wavelength_coarse * std::pow(r, u);
  const double two_pi = 2 * std::numbers::pi;
  const double phase_x = two_pi * L / P.detail_wavelength_coarse * (std::pow(r, -u) - 1) / std::log(1 / r);
  const double phase_z = two_pi * q.z() / lambda;
  const double depth = P.detail_depth_min + (P.detail_depth_max - P.detail_depth_min) * u;
  return w * depth * (0.5 + 0.5 * std::sin(phase_x) * std::sin(phase_z));
}

ProceduralObject::Parts ProceduralObject::parts(const Vec3& q) const {
  const auto& P = params_;
  Parts d{};
  d.body = (rounded_box(q, Vec3::Zero(), P.body_half, P.body_rounding) + engraving(q)) / body_lipschitz_;
  {  // fin: a disc in the XZ plane, centred on the top face, edges fully rounded
    const double ra = 0.5 * P.fin_thickness;
    const double dx = std::hypot(q.x(), q.z() - P.body_half.z()) - (P.fin_radius - ra);
    const double dy = std::abs(q.y());
    d.fin = std::min(std::max(dx, dy), 0.0) + std::hypot(std::max(dx, 0.0), std::max(dy, 0.0)) - ra;
  }
  {  // hood: a box open at the bottom and on the body side, attached to the -X face
    const double x0 = -P.body_half.x() - P.hood_depth, x1 = -P.body_half.x() + 0.01;
    const Vec3 lo(x0, -P.hood_half_width, P.hood_bottom), hi(x1, P.hood_half_width, P.hood_top);
    const double outer = rounded_box(q, 0.5 * (lo + hi), 0.5 * (hi - lo), 0.008);
    const Vec3 clo(x0 + P.hood_wall, -P.hood_half_width + P.hood_wall, P.hood_bottom - 1.0);
    const Vec3 chi(-P.body_half.x() + 0.05, P.hood_half_width - P.hood_wall, P.hood_top - P.hood_wall);
    const double cavity = rounded_box(q, 0.5 * (clo + chi), 0.5 * (chi - clo), 0.0);
    d.hood = std::max(outer, -cavity);
  }
  {  // handle: a torus in the XZ plane crossing the +X face
    const double a = std::hypot(q.x() - P.handle_center_x, q.z() - P.handle_center_z) - P.handle_major;
    d.handle = std::hypot(a, q.y()) - P.handle_minor;
  }
  return d;
}

double ProceduralObject::sdf_design(const Vec3& q) const {
  const Parts d = parts(q);
  double s = smin(d.body, d.fin, 0.015);
  s = smin(s, d.handle, 0.03);
  return std::min(s, d.hood);
}

double ProceduralObject::sdf(const Vec3& p) const {
  const Similarity inv = to_world_.inverse();
  return to_world_.scale * sdf_design(inv.apply(p));
}

Vec3 ProceduralObject::normal(const Vec3& p) const {
  const double e = 1e-5;
  Vec3 g;
  for (int a = 0; a < 3; ++a) {
    Vec3 d = Vec3::Zero();
    d[a] = e;
    g[a] = sdf(p + d) - sdf(p - d);
  }
  const double l = g.norm();
  return l > 0 ? Vec3(g / l) : Vec3::UnitZ();
}

TriangleMesh ProceduralObject::mesh(int resolution) const {
  AABB box = bounds();
  const double pad = 0.02;
  box.min -= Vec3::Constant(pad);
  box.max += Vec3::Constant(pad);
  return mesh_implicit([this](const Vec3& p) { return sdf(p); }, box, resolution);
}

ProceduralObject::Region ProceduralObject::region(const Vec3& surface_point) const {
  const auto& P = params_;
  const Vec3 q = to_world_.inverse().apply(surface_point);
  const Parts d = parts(q);
  const double b = std::abs(d.body), f = std::abs(d.fin), h = std::abs(d.hood), l = std::abs(d.handle);
  if (f < b && f <= h && f <= l) return Region::thin;
  if (h < b && h <= l) return Region::overhang;
  if (l < b) return Region::handle;
  if (q.x() < -P.body_half.x() + 0.02 && std::abs(q.y()) < P.hood_half_width && q.z() > P.hood_bottom &&
      q.z() < P.hood_top)
    return Region::overhang;
  if (detail_window(q) > 0 && q.y() < 0) return Region::detail;
  return Region::smooth;
}

const char* ProceduralObject::region_name(Region r) {
  switch (r) {
    case Region::smooth:
      return "smooth";
    case Region::detail:
      return "detail";
    case Region::thin:
      return "thin";
    case Region::overhang:
      return "overhang";
    case Region::handle:
      return "handle";
  }
  return "unknown";
}

}  // namespace autoscan
