#pragma once
// An 8-bit RGB raster: the report's figures (io/image.hpp writes and reads it as PNG) and a mesh's
// colour texture (core/mesh.hpp, OBJ `map_Kd`).
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan {

/// An 8-bit RGB image, row-major, top row first: pixel (x, y) is pixels[y * width + x].
struct Image {
  int width = 0;
  int height = 0;
  std::vector<Rgb> pixels;

  Image() = default;
  Image(int w, int h, Rgb fill = {255, 255, 255})
      : width(w), height(h), pixels(static_cast<std::size_t>(w) * h, fill) {}
  bool empty() const { return width <= 0 || height <= 0 || pixels.empty(); }
  Rgb& at(int x, int y) { return pixels[static_cast<std::size_t>(y) * width + x]; }
  const Rgb& at(int x, int y) const { return pixels[static_cast<std::size_t>(y) * width + x]; }
  /// The colour at texture coordinates (u, v) as OBJ defines them: u to the right, v up (v = 0 is
  /// the bottom row), wrapped into [0, 1) (repeat), clamped to the edge pixels. Bilinear between the four nearest pixel
  /// centres (0-255 per channel, not rounded). Zero for an empty image.
  Vec3 sample(double u, double v) const;
};

}  // namespace autoscan
