#pragma once
// RGB raster images and PNG output (libpng), for the report's figures and plots.
#include <filesystem>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::io {

/// An 8-bit RGB image, row-major, top row first: pixel (x, y) is pixels[y * width + x].
struct Image {
  int width = 0;
  int height = 0;
  std::vector<Rgb> pixels;

  Image() = default;
  Image(int w, int h, Rgb fill = {255, 255, 255})
      : width(w), height(h), pixels(static_cast<std::size_t>(w) * h, fill) {}
  Rgb& at(int x, int y) { return pixels[static_cast<std::size_t>(y) * width + x]; }
  const Rgb& at(int x, int y) const { return pixels[static_cast<std::size_t>(y) * width + x]; }
};

/// Writes `image` as an 8-bit RGB PNG through write_file_atomic. Throws InputError when the size
/// is not positive or does not match the pixel count, RuntimeError when encoding fails.
void write_png(const std::filesystem::path& path, const Image& image);

/// Reads a PNG (any colour type, converted to 8-bit RGB, alpha dropped). Throws InputError naming
/// the path when it is missing or not a valid PNG.
Image read_png(const std::filesystem::path& path);

}  // namespace autoscan::io
