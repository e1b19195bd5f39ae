#include "autoscan/io/image.hpp"

#include <png.h>

#include <cstring>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/io/detail_parse.hpp"

namespace autoscan::io {

void write_png(const std::filesystem::path& path, const Image& image) {
  const std::string p = path.string();
  AUTOSCAN_REQUIRE(image.width > 0 && image.height > 0, "{}: image size {}x{} is not positive", p, image.width,
                   image.height);
  AUTOSCAN_REQUIRE(image.pixels.size() == static_cast<std::size_t>(image.width) * image.height,
                   "{}: {} pixels for a {}x{} image", p, image.pixels.size(), image.width, image.height);
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width);
  png.height = static_cast<png_uint_32>(image.height);
  png.format = PNG_FORMAT_RGB;
  static_assert(sizeof(Rgb) == 3, "Rgb must be three packed bytes");
  const auto* buffer = reinterpret_cast<const void*>(image.pixels.data());
  png_alloc_size_t size = 0;
  // First call sizes the output, second call encodes.
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, buffer, 0, nullptr))
    throw RuntimeError(fmt::format("{}: PNG encoding failed: {}", p, png.message));
  std::string bytes(size, '\0');
  if (!png_image_write_to_memory(&png, bytes.data(), &size, 0, buffer, 0, nullptr))
    throw RuntimeError(fmt::format("{}: PNG encoding failed: {}", p, png.message));
  bytes.resize(size);
  png_image_free(&png);
  write_text_atomic(path, bytes);
}

Image read_png(const std::filesystem::path& path) {
  const std::string p = path.string();
  const std::string bytes = detail::load_file(path);
  png_image png;
  std::memset(&png, 0, sizeof(png));
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size()))
    detail::fail(p, "not a valid PNG file ({})", png.message);
  png.format = PNG_FORMAT_RGB;
  Image img(static_cast<int>(png.width), static_cast<int>(png.height));
  if (!png_image_finish_read(&png, nullptr, img.pixels.data(), 0, nullptr)) {
    const std::string msg = png.message;
    png_image_free(&png);
    detail::fail(p, "cannot decode PNG ({})", msg);
  }
  return img;
}

}  // namespace autoscan::io
