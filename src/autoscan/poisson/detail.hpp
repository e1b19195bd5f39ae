#pragma once
// Internals of the Poisson stage shared by the solver, the field and the extractor: packed node
// keys, a read-only hash index over sorted keys, and the stored field.
#include <atomic>
#include <cstdint>
#include <span>
#include <vector>

#include "autoscan/core/types.hpp"

namespace autoscan::poisson::detail {

/// Grid coordinates (x, y, z) at one depth packed into 63 bits, x in the lowest 21.
constexpr int kKeyBits = 21;
constexpr std::uint64_t kKeyMask = (std::uint64_t{1} << kKeyBits) - 1;
constexpr std::uint64_t kNoKey = ~std::uint64_t{0};

inline std::uint64_t pack(int x, int y, int z) {
  return std::uint64_t(x) | (std::uint64_t(y) << kKeyBits) | (std::uint64_t(z) << (2 * kKeyBits));
}
inline int key_x(std::uint64_t k) { return int(k & kKeyMask); }
inline int key_y(std::uint64_t k) { return int((k >> kKeyBits) & kKeyMask); }
inline int key_z(std::uint64_t k) { return int((k >> (2 * kKeyBits)) & kKeyMask); }

/// Open-addressing (linear probing) map from key to its position in the array it was built from.
/// Built once (in parallel), then read concurrently.
class KeyIndex {
 public:
  void build(std::span<const std::uint64_t> keys);
  /// Position of `key`, or -1.
  int find(std::uint64_t key) const {
    if (slots_.empty()) return -1;
    std::uint64_t h = mix(key) & mask_;
    while (true) {
      const std::uint64_t s = slots_[h];
      if (s == key) return vals_[h];
      if (s == kNoKey) return -1;
      h = (h + 1) & mask_;
    }
  }
  std::size_t memory_bytes() const { return slots_.size() * (sizeof(std::uint64_t) + sizeof(std::int32_t)); }

  static std::uint64_t mix(std::uint64_t x) {
    x ^= x >> 31;
    x *= 0x7fb5d329728ea185ULL;
    x ^= x >> 27;
    x *= 0x81dadef4bc2dd44dULL;
    x ^= x >> 33;
    return x;
  }

 private:
  std::vector<std::uint64_t> slots_;
  std::vector<std::int32_t> vals_;
  std::uint64_t mask_ = 0;
};

/// One depth of the stored solution: the node keys (sorted), their index, and the total solution
/// chi_{<=d} (all depths up to d) at those nodes. chi_{<=d} is trilinear on depth-d cells; a cell
/// whose 8 corners are all stored carries the whole field (finer depths add nothing there).
struct FieldLevel {
  int depth = 0;
  std::vector<std::uint64_t> keys;
  KeyIndex index;
  std::vector<double> value;
};

struct FieldData {
  Vec3 origin = Vec3::Zero();  ///< min corner of the bounding cube
  double width = 1.0;          ///< side of the bounding cube
  int max_depth = 0;           ///< requested D
  double iso = 0.0;
  double reference_gradient = 0.0;
  std::vector<FieldLevel> levels;  ///< depths 0..finest
  /// Sample density (weighted samples per unit area, unit-cube units) at the corners of the cells
  /// holding samples at the density depth, trilinear in between, zero elsewhere.
  FieldLevel density;

  /// Finds the deepest level whose cell around u (unit-cube coordinates, clamped) has all corners
  /// stored; returns the level, writes the corner indices and the local coordinates in the cell.
  int locate(const Vec3& u, int corner[8], double t[3]) const;
  /// chi and its gradient (unit-cube units) at unit-cube point u.
  double eval(const Vec3& u, Vec3* grad) const;
  /// chi at grid node (x,y,z) of depth `d`.
  double node_value(int d, int x, int y, int z) const;
};

}  // namespace autoscan::poisson::detail
