#pragma once
// RGB raster images and PNG output (libpng), for the report's figures and plots.
#include <filesystem>
#include <vector>

#include "autoscan/core/image.hpp"

namespace autoscan::io {

/// The 8-bit RGB image of core (core/image.hpp), kept under this name for the writers.
using Image = autoscan::Image;

/// Writes `image` as an 8-bit RGB PNG through write_file_atomic. Throws InputError when the size
/// is not positive or does not match the pixel count, RuntimeError when encoding fails.
void write_png(const std::filesystem::path& path, const Image& image);

/// Reads a PNG (any colour type, converted to 8-bit RGB, alpha dropped). Throws InputError naming
/// the path when it is missing or not a valid PNG.
Image read_png(const std::filesystem::path& path);

}  // namespace autoscan::io
