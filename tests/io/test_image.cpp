// PNG round trip, colour map end points and monotonicity, normalisation to the benchmark frame.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "autoscan/core/error.hpp"
#include "autoscan/io/colormap.hpp"
#include "autoscan/io/image.hpp"
#include "autoscan/io/normalize.hpp"
#include "io_test_util.hpp"

using namespace autoscan;
using namespace autoscan::io;

TEST(Image, PngRoundTripIsExact) {
  const auto dir = autoscan::testing::temp_dir("png");
  Image img(37, 21);
  for (int y = 0; y < img.height; ++y)
    for (int x = 0; x < img.width; ++x)
      img.at(x, y) = {static_cast<std::uint8_t>(7 * x), static_cast<std::uint8_t>(11 * y),
                      static_cast<std::uint8_t>(x ^ y)};
  write_png(dir / "a.png", img);
  const Image back = read_png(dir / "a.png");
  EXPECT_EQ(back.width, img.width);
  EXPECT_EQ(back.height, img.height);
  EXPECT_EQ(back.pixels, img.pixels);
  EXPECT_THROW(write_png(dir / "b.png", Image()), InputError);
  Image bad(4, 4);
  bad.pixels.pop_back();
  EXPECT_THROW(write_png(dir / "c.png", bad), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir / "b.png"));
  EXPECT_FALSE(std::filesystem::exists(dir / "c.png"));
  autoscan::testing::write_bytes(dir / "d.png", "not a png at all");
  EXPECT_THROW(read_png(dir / "d.png"), InputError);
  std::filesystem::remove_all(dir);
}

TEST(Colormap, BlueLowRedHighMonotone) {
  EXPECT_EQ(colormap(0.0), (Rgb{0, 0, 255}));
  EXPECT_EQ(colormap(0.5), (Rgb{0, 255, 0}));
  EXPECT_EQ(colormap(1.0), (Rgb{255, 0, 0}));
  EXPECT_EQ(colormap(-3.0), colormap(0.0));
  EXPECT_EQ(colormap(7.0), colormap(1.0));
  EXPECT_EQ(colormap(std::nan("")), (Rgb{128, 128, 128}));
  // Red never decreases and blue never increases along the map.
  Rgb prev = colormap(0.0);
  for (int i = 1; i <= 1000; ++i) {
    const Rgb c = colormap(i / 1000.0);
    EXPECT_GE(c[0], prev[0]);
    EXPECT_LE(c[2], prev[2]);
    prev = c;
  }
  EXPECT_EQ(colormap_diverging(0.5), (Rgb{255, 255, 255}));
  EXPECT_GT(colormap_diverging(0.0)[2], colormap_diverging(0.0)[0]);
  EXPECT_GT(colormap_diverging(1.0)[0], colormap_diverging(1.0)[2]);
}

TEST(Normalize, UnitDiagonalCentredAndInvertible) {
  TriangleMesh m = autoscan::testing::torus(10, 6, 3.0, 0.5, Vec3(10, -4, 2));
  const TriangleMesh before = m;
  const Similarity s = normalize_to_unit_diagonal(m);
  const AABB b = m.bounds();
  EXPECT_NEAR(b.diagonal(), 1.0, 1e-12);
  EXPECT_LT(b.center().norm(), 1e-12);
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    EXPECT_LT((s.apply(before.vertices[i]) - m.vertices[i]).norm(), 1e-12);
    EXPECT_LT((s.invert(m.vertices[i]) - before.vertices[i]).norm(), 1e-12);
    const Eigen::Vector4d h = s.matrix() * before.vertices[i].homogeneous();
    EXPECT_LT((h.head<3>() - m.vertices[i]).norm(), 1e-12);
  }
  PointCloud one;
  one.positions = {Vec3(1, 1, 1), Vec3(1, 1, 1)};
  EXPECT_THROW(normalize_to_unit_diagonal(one), InputError);
  PointCloud none;
  EXPECT_THROW(normalize_to_unit_diagonal(none), InputError);
}
