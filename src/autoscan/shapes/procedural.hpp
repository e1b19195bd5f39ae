#pragma once
// The built-in demo object (issue 2): one watertight solid of genus 1 with
//  * smooth regions — a rounded box body (back, top, bottom and side faces);
//  * spatially varying fine detail — the front face (-Y) carries engraved bumps whose frequency and
//    amplitude both grow along +X (in the spirit of the paper's Figure 4 test shape): wavelength
//    from `detail_wavelength_coarse` to `detail_wavelength_fine`, depth up to `detail_depth_max`;
//  * a thin part — a rounded fin on top, thickness `fin_thickness` of the design frame, i.e. about
//    1.4 % of the bounding-box diagonal (about 3 cells at the default meshing resolution);
//  * an overhang that self-occludes — a hood on the -X side, an inverted U-shaped channel capped on
//    top and open only at the bottom: the body wall under it is hidden from every horizontal view;
//  * a handle — a torus loop on the +X side fused to the body at both ends (genus 1).
// Frame: the normalised benchmark frame, bounding-box diagonal 1, centred at the origin, Z up. The
// object is designed in a "design frame" (units below) whose analytic bounding box is mapped there
// by the similarity `design_to_world()`.
#include "autoscan/core/mesh.hpp"
#include "autoscan/core/types.hpp"
#include "autoscan/shapes/normalize.hpp"

namespace autoscan {

class ProceduralObject {
 public:
  enum class Region { smooth, detail, thin, overhang, handle };

  /// Design parameters (design-frame units; the frame's bounding box is derived from them).
  struct Params {
    Vec3 body_half = {0.25, 0.20, 0.30};     ///< half extents of the rounded-box body
    double body_rounding = 0.05;             ///< edge radius of the body
    double fin_radius = 0.12;                ///< half-disc fin on top of the body
    double fin_thickness = 0.016;            ///< full thickness of the fin (thin part)
    double detail_wavelength_coarse = 0.10;  ///< bump wavelength at the -X end of the front face
    double detail_wavelength_fine = 0.025;   ///< ... and at the +X end
    double detail_depth_min = 0.004;         ///< bump depth at the -X end
    double detail_depth_max = 0.008;         ///< ... and at the +X end
    double hood_depth = 0.13;                ///< how far the hood sticks out of the -X face
    double hood_half_width = 0.13;           ///< half extent of the hood along Y
    double hood_top = 0.12;                  ///< Z of the hood's top
    double hood_bottom = -0.06;              ///< Z of the hood's open bottom edge
    double hood_wall = 0.025;                ///< wall and plate thickness of the hood
    double handle_major = 0.11;              ///< handle loop radius (torus in the XZ plane)
    double handle_minor = 0.025;             ///< handle tube radius
    double handle_center_x = 0.33;           ///< X of the loop's centre (the body's +X face is at 0.25)
    double handle_center_z = -0.05;          ///< Z of the loop's centre
  };

  ProceduralObject();
  explicit ProceduralObject(const Params& params);

  /// Signed distance bound in the world (normalised) frame: negative inside, zero on the surface, and
  /// |sdf(p)| never larger than the true distance to the surface (a 1-Lipschitz function). Exact away
  /// from the engraved face and the blends. Thread-safe.
  double sdf(const Vec3& p) const;
  bool inside(const Vec3& p) const { return sdf(p) < 0; }
  /// Outward unit normal of the level set through p (central differences of sdf).
  Vec3 normal(const Vec3& p) const;
  /// Watertight, consistently outward-oriented mesh of genus 1 by marching tetrahedra; `resolution`
  /// cells along the longest side. About 100k triangles at the default.
  TriangleMesh mesh(int resolution = 150) const;
  /// The region a point on (or near) the surface belongs to: the part whose surface is nearest, and
  /// for the body, `detail` on the engraved face, `overhang` on the wall hidden under the hood.
  Region region(const Vec3& surface_point) const;

  /// Design frame → world frame (scale, translation).
  const Similarity& design_to_world() const { return to_world_; }
  /// Analytic bounding box in the world frame (diagonal 1, centred at the origin).
  AABB bounds() const;
  const Params& params() const { return params_; }

  static const char* region_name(Region r);

 private:
  struct Parts {
    double body, fin, hood, handle;
  };
  Parts parts(const Vec3& q) const;  // q in the design frame
  double sdf_design(const Vec3& q) const;
  double engraving(const Vec3& q) const;  // >= 0, depth of the bumps at q
  double detail_window(const Vec3& q) const;

  Params params_;
  AABB design_box_;
  Similarity to_world_;
  double body_lipschitz_ = 1.0;
};

}  // namespace autoscan
