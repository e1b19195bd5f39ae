// The stored screened Poisson field: evaluation of chi, its exact gradient and the density estimate.
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>

#include "autoscan/core/error.hpp"
#include "autoscan/poisson/detail.hpp"
#include "autoscan/poisson/poisson.hpp"

namespace autoscan::poisson {
namespace detail {

void KeyIndex::build(std::span<const std::uint64_t> keys) {
  std::size_t cap = 16;
  while (cap < 2 * keys.size()) cap <<= 1;
  slots_.assign(cap, kNoKey);
  vals_.assign(cap, -1);
  mask_ = cap - 1;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, keys.size(), 4096), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      const std::uint64_t key = keys[i];
      std::uint64_t h = mix(key) & mask_;
      while (true) {
        std::atomic_ref<std::uint64_t> slot(slots_[h]);
        std::uint64_t expected = kNoKey;
        if (slot.compare_exchange_strong(expected, key, std::memory_order_relaxed)) {
          vals_[h] = static_cast<std::int32_t>(i);
          break;
        }
        h = (h + 1) & mask_;
      }
    }
  });
}

int FieldData::locate(const Vec3& u, int corner[8], double t[3]) const {
  for (int d = static_cast<int>(levels.size()) - 1; d >= 0; --d) {
    const FieldLevel& L = levels[d];
    const int n = 1 << d;
    int c[3];
    for (int a = 0; a < 3; ++a) {
      const double s = std::clamp(u[a], 0.0, 1.0) * n;
      c[a] = std::clamp(static_cast<int>(std::floor(s)), 0, n - 1);
      t[a] = s - c[a];
    }
    bool ok = true;
    for (int k = 0; k < 8 && ok; ++k) {
      corner[k] = L.index.find(pack(c[0] + (k & 1), c[1] + ((k >> 1) & 1), c[2] + ((k >> 2) & 1)));
      ok = corner[k] >= 0;
    }
    if (ok) return d;
  }
  return -1;
}

double FieldData::eval(const Vec3& u, Vec3* grad) const {
  int corner[8];
  double t[3];
  const int d = locate(u, corner, t);
  if (d < 0) {
    if (grad) grad->setZero();
    return 0.0;
  }
  const std::vector<double>& q = levels[d].value;
  double v = 0.0;
  Vec3 g = Vec3::Zero();
  for (int k = 0; k < 8; ++k) {
    const int bx = k & 1, by = (k >> 1) & 1, bz = (k >> 2) & 1;
    const double wx = bx ? t[0] : 1.0 - t[0], wy = by ? t[1] : 1.0 - t[1], wz = bz ? t[2] : 1.0 - t[2];
    const double qk = q[corner[k]];
    v += wx * wy * wz * qk;
    if (grad) {
      g.x() += (bx ? 1.0 : -1.0) * wy * wz * qk;
      g.y() += (by ? 1.0 : -1.0) * wx * wz * qk;
      g.z() += (bz ? 1.0 : -1.0) * wx * wy * qk;
    }
  }
  if (grad) *grad = g * static_cast<double>(1 << d);
  return v;
}

double FieldData::node_value(int d, int x, int y, int z) const {
  if (d < static_cast<int>(levels.size())) {
    const int i = levels[d].index.find(pack(x, y, z));
    if (i >= 0) return levels[d].value[i];
  }
  const double s = 1.0 / static_cast<double>(1 << d);
  return eval(Vec3(x * s, y * s, z * s), nullptr);
}

}  // namespace detail

PoissonField::PoissonField(std::shared_ptr<const detail::FieldData> data) : data_(std::move(data)) {
  AUTOSCAN_CHECK(data_ && !data_->levels.empty(), "PoissonField: empty field");
}
PoissonField::~PoissonField() = default;

double PoissonField::value(const Vec3& p) const { return data_->eval((p - data_->origin) / data_->width, nullptr); }

Vec3 PoissonField::gradient(const Vec3& p) const {
  const Vec3 u = (p - data_->origin) / data_->width;
  if ((u.array() < 0.0).any() || (u.array() > 1.0).any()) return Vec3::Zero();
  Vec3 g;
  data_->eval(u, &g);
  return g / data_->width;
}

double PoissonField::iso_value() const { return data_->iso; }

void PoissonField::values(std::span<const Vec3> pts, std::span<double> out) const {
  AUTOSCAN_CHECK(pts.size() == out.size(), "PoissonField::values: {} points but {} outputs", pts.size(), out.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pts.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) out[i] = value(pts[i]);
  });
}

void PoissonField::gradients(std::span<const Vec3> pts, std::span<Vec3> out) const {
  AUTOSCAN_CHECK(pts.size() == out.size(), "PoissonField::gradients: {} points but {} outputs", pts.size(), out.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, pts.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) out[i] = gradient(pts[i]);
  });
}

double PoissonField::reference_gradient() const { return data_->reference_gradient; }
double PoissonField::finest_cell_width() const { return data_->width / static_cast<double>(1 << data_->max_depth); }
AABB PoissonField::bounding_cube() const {
  AABB b;
  b.extend(data_->origin);
  b.extend(Vec3(data_->origin + Vec3::Constant(data_->width)));
  return b;
}
int PoissonField::depth() const { return data_->max_depth; }
int PoissonField::finest_depth() const { return static_cast<int>(data_->levels.size()) - 1; }

double PoissonField::density(const Vec3& p) const {
  const Vec3 u = (p - data_->origin) / data_->width;
  if ((u.array() < 0.0).any() || (u.array() > 1.0).any()) return 0.0;
  const detail::FieldLevel& L = data_->density;
  const int n = 1 << L.depth;
  int c[3];
  double t[3];
  for (int a = 0; a < 3; ++a) {
    const double s = u[a] * n;
    c[a] = std::clamp(static_cast<int>(std::floor(s)), 0, n - 1);
    t[a] = s - c[a];
  }
  double v = 0.0;
  for (int k = 0; k < 8; ++k) {
    const int bx = k & 1, by = (k >> 1) & 1, bz = (k >> 2) & 1;
    const int i = L.index.find(detail::pack(c[0] + bx, c[1] + by, c[2] + bz));
    if (i < 0) continue;
    v += (bx ? t[0] : 1.0 - t[0]) * (by ? t[1] : 1.0 - t[1]) * (bz ? t[2] : 1.0 - t[2]) * L.value[i];
  }
  return v / (data_->width * data_->width);
}

std::vector<float> PoissonField::sample_grid(int res) const {
  AUTOSCAN_REQUIRE(res >= 2 && res <= 2048, "grid resolution {} out of range [2, 2048]", res);
  const std::size_t r = static_cast<std::size_t>(res);
  std::vector<float> out(r * r * r);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, r * r), [&](const auto& rg) {
    for (std::size_t zy = rg.begin(); zy != rg.end(); ++zy) {
      const std::size_t z = zy / r, y = zy % r;
      for (std::size_t x = 0; x < r; ++x) {
        const Vec3 u((x + 0.5) / res, (y + 0.5) / res, (z + 0.5) / res);
        out[(z * r + y) * r + x] = static_cast<float>(data_->eval(u, nullptr));
      }
    }
  });
  return out;
}

}  // namespace autoscan::poisson
