#pragma once
// The one colour map every stage uses to show confidence and other values in [0, 1].
//
// colormap(t) is a jet-like rainbow map as in the paper's figures (Figs. 2, 4, 5: "high confidence
// areas are shown in red and low confidence in blue"): piecewise linear through
//   t = 0 blue (0,0,255) · 0.25 cyan (0,255,255) · 0.5 green (0,255,0) · 0.75 yellow (255,255,0) · 1 red (255,0,0).
// colormap_diverging(t) is a perceptual blue-white-red alternative (Moreland's cool-warm end points,
// linear in RGB through white), for signed quantities centred at t = 0.5.
// Both clamp t to [0, 1]; NaN gives mid grey (128,128,128).
#include "autoscan/core/types.hpp"

namespace autoscan::io {

/// Jet-like blue (t = 0, low) → cyan → green → yellow → red (t = 1, high).
Rgb colormap(double t);

/// Blue (t = 0) → white (t = 0.5) → red (t = 1).
Rgb colormap_diverging(double t);

}  // namespace autoscan::io
