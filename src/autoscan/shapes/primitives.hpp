#pragma once
// Closed, outward-oriented (counter-clockwise seen from outside) analytic test meshes.
#include "autoscan/core/mesh.hpp"

namespace autoscan {

/// Icosahedron centred at `center` subdivided `subdivisions` times (20·4^s faces), vertices
/// projected on the sphere of `radius`. Genus 0. Throws InputError for radius <= 0 or s outside [0, 9].
TriangleMesh icosphere(double radius, int subdivisions, const Vec3& center = Vec3::Zero());

/// Torus around the Z axis centred at `center`: major radius R (centre of the tube), minor radius r,
/// nu segments around Z, nv around the tube (2·nu·nv faces). Genus 1. Requires 0 < r < R, nu, nv >= 3.
TriangleMesh torus(double R, double r, int nu, int nv, const Vec3& center = Vec3::Zero());

/// Axis-aligned box: 8 vertices, 12 faces. Requires min < max on every axis.
TriangleMesh box(const Vec3& min, const Vec3& max);

}  // namespace autoscan
