// Outputs of the nbv stage: views JSON (docs/conventions.md), the field as NRRD, a slice as PNG.
#include <png.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <cstring>
#include <nlohmann/json.hpp>
#include <ostream>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/nbv/nbv.hpp"

namespace autoscan::nbv {

namespace {
nlohmann::json arr(const Vec3& v) { return nlohmann::json::array({v.x(), v.y(), v.z()}); }
}  // namespace

nlohmann::json views_to_json(const PlanResult& result) {
  nlohmann::json views = nlohmann::json::array();
  for (const auto& v : result.views) {
    nlohmann::json j = to_json(v.pose);
    j["score"] = v.score;
    j["target"] = arr(v.target);
    if (v.gain > 0.0) j["gain"] = v.gain;
    if (v.region) j["region"] = v.region_id;
    views.push_back(std::move(j));
  }
  return {{"views", std::move(views)}, {"path_length", result.path_length}};
}

void write_views_json(const std::filesystem::path& path, const PlanResult& result) {
  write_text_atomic(path, views_to_json(result).dump(2) + "\n");
}

nlohmann::json diagnostics_to_json(const NbvDiagnostics& d) {
  return {{"iso_points", d.iso_points},
          {"active_points", d.active_points},
          {"voxels", d.voxels},
          {"candidates", d.candidates},
          {"clusters", d.clusters},
          {"pair_evaluations", d.pair_evaluations},
          {"rays_cast", d.rays_cast},
          {"bound_evaluations", d.bound_evaluations},
          {"cell_maxima", d.cell_maxima},
          {"above_threshold", d.above_threshold},
          {"dropped_unreachable", d.dropped_unreachable},
          {"unreachable_voxels", d.unreachable_voxels},
          {"dropped_out_of_range", d.dropped_out_of_range},
          {"pool", d.pool},
          {"regions", d.regions},
          {"regions_searched", d.regions_searched},
          {"region_views", d.region_views},
          {"region_views_chosen", d.region_views_chosen},
          {"rays_select", d.rays_select},
          {"need", d.need},
          {"gain", d.gain},
          {"nn_path_length", d.nn_path_length},
          {"seconds",
           {{"space", d.seconds_space},
            {"field", d.seconds_field},
            {"select", d.seconds_select},
            {"path", d.seconds_path},
            {"total", d.seconds_total}}},
          {"messages", d.messages}};
}

void write_field_nrrd(const std::filesystem::path& path, const ViewingField& field) {
  const auto& g = field.grid;
  AUTOSCAN_REQUIRE(field.g.size() == g.size() && g.size() > 0, "{}: the field is empty", path.string());
  const Vec3 c0 = g.center(0, 0, 0);
  std::string header = "NRRD0004\n# autoscan viewing vector field magnitude g (Wu et al. 2014, Eq. 4)\n";
  header += "type: float\ndimension: 3\nspace dimension: 3\n";
  header += fmt::format("sizes: {} {} {}\n", g.dims[0], g.dims[1], g.dims[2]);
  header += "space directions:";
  for (int a = 0; a < 3; ++a) {
    const Vec3 d = g.axes.col(a) * g.spacing[a];
    header += fmt::format(" ({:.17g},{:.17g},{:.17g})", d.x(), d.y(), d.z());
  }
  header += fmt::format("\nspace origin: ({:.17g},{:.17g},{:.17g})\n", c0.x(), c0.y(), c0.z());
  header += "centerings: cell cell cell\nkinds: space space space\nendian: little\nencoding: raw\n\n";
  write_file_atomic(path, [&](std::ostream& os) {
    os.write(header.data(), static_cast<std::streamsize>(header.size()));
    std::vector<float> data(field.g.begin(), field.g.end());
    static_assert(sizeof(float) == 4);
    // x86-64 and aarch64 are little-endian; the header says so.
    os.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size() * sizeof(float)));
  });
}

namespace {

std::array<std::uint8_t, 3> jet(double t) {
  t = std::clamp(t, 0.0, 1.0);
  auto ch = [&](double c) {
    return static_cast<std::uint8_t>(std::lround(255.0 * std::clamp(1.5 - std::abs(4.0 * t - c), 0.0, 1.0)));
  };
  return {ch(3.0), ch(2.0), ch(1.0)};
}

void png_write_cb(png_structp png, png_bytep data, png_size_t len) {
  auto* buf = static_cast<std::vector<std::uint8_t>*>(png_get_io_ptr(png));
  buf->insert(buf->end(), data, data + len);
}
void png_flush_cb(png_structp) {}

// Encodes RGB rows into `out`; false on a libpng error (libpng longjmps back here; no C++ objects
// with destructors live in this frame).
bool encode_rgb_png(int w, int h, const std::uint8_t* rgb, std::vector<std::uint8_t>* out) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info || setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_set_write_fn(png, out, png_write_cb, png_flush_cb);
  png_set_IHDR(png, info, static_cast<png_uint_32>(w), static_cast<png_uint_32>(h), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  for (int y = 0; y < h; ++y) png_write_row(png, const_cast<png_bytep>(rgb + std::size_t(y) * std::size_t(w) * 3));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

// Small local RGB PNG writer (the io stage's image writer was not available when this was written).
void write_rgb_png(const std::filesystem::path& path, int w, int h, const std::vector<std::uint8_t>& rgb) {
  std::vector<std::uint8_t> bytes;
  AUTOSCAN_CHECK(encode_rgb_png(w, h, rgb.data(), &bytes), "{}: PNG encoding failed", path.string());
  write_file_atomic(path, [&](std::ostream& os) {
    os.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  });
}

}  // namespace

void write_slice_png(const std::filesystem::path& path, const ViewingField& field, const Vec3& center,
                     const std::vector<NbvView>& views, int min_pixels) {
  const auto& g = field.grid;
  AUTOSCAN_REQUIRE(field.g.size() == g.size() && g.size() > 0, "{}: the field is empty", path.string());
  const int nx = g.dims[0], ny = g.dims[1];
  const int layer = std::clamp(static_cast<int>(std::floor(g.to_local(center).z() / g.spacing.z())), 0, g.dims[2] - 1);
  const int s = std::max(1, (std::max(min_pixels, 1) + std::max(nx, ny) - 1) / std::max(nx, ny));
  const int W = nx * s, H = ny * s;
  std::vector<std::uint8_t> img(std::size_t(W) * H * 3, 0);
  const double gmax = std::max(1e-12, *std::max_element(field.g.begin(), field.g.end()));
  for (int py = 0; py < H; ++py)
    for (int px = 0; px < W; ++px) {
      const int i = px / s, j = ny - 1 - py / s;  // image y goes down, box y up
      const std::size_t v = g.index(i, j, layer);
      std::array<std::uint8_t, 3> c{0, 0, 0};
      switch (field.state[v]) {
        case VoxelState::candidate:
          c = jet(field.g[v] / gmax);
          break;
        case VoxelState::inside:
          c = {70, 70, 70};
          break;
        case VoxelState::too_close:
          c = {25, 25, 25};
          break;
        case VoxelState::unreachable:
          c = {60, 30, 75};
          break;
        case VoxelState::too_far:
          break;
      }
      std::memcpy(&img[(std::size_t(py) * W + px) * 3], c.data(), 3);
    }
  auto put = [&](double x, double y, std::array<std::uint8_t, 3> c) {
    const int ix = static_cast<int>(std::lround(x)), iy = static_cast<int>(std::lround(y));
    if (ix < 0 || iy < 0 || ix >= W || iy >= H) return;
    std::memcpy(&img[(std::size_t(iy) * W + ix) * 3], c.data(), 3);
  };
  const double r = std::max(3.0, 1.2 * s);
  for (const auto& view : views) {
    const Vec3 l = g.to_local(view.pose.position);
    const double x = l.x() / g.spacing.x() * s, y = H - l.y() / g.spacing.y() * s;
    for (int t = 0; t < 64; ++t) {
      const double a = 2.0 * M_PI * t / 64.0;
      put(x + r * std::cos(a), y + r * std::sin(a), {255, 255, 255});
    }
    const Vec3 d = g.axes.transpose() * view.pose.direction;
    const Eigen::Vector2d dd(d.x() / g.spacing.x(), -d.y() / g.spacing.y());
    if (dd.norm() > 1e-12) {
      const Eigen::Vector2d u = dd.normalized() * (std::hypot(d.x(), d.y()) / std::max(d.norm(), 1e-12));
      const double len = 6.0 * r;
      for (int t = 0; t <= 200; ++t) put(x + u.x() * len * t / 200.0, y + u.y() * len * t / 200.0, {255, 255, 255});
    }
  }
  write_rgb_png(path, W, H, img);
}

}  // namespace autoscan::nbv
