#pragma once
// Union-find (disjoint sets) with path halving: the connected components of a graph given edge by
// edge. Shared by mesh topology checks, view-region clustering, the quality certificate's regions
// and the multiway registration's groups of scans.
#include <cstddef>
#include <numeric>
#include <vector>

namespace autoscan {

class UnionFind {
 public:
  explicit UnionFind(std::size_t n = 0) { reset(n); }

  /// n singletons again (keeps the storage: for a small union-find reused in a loop).
  void reset(std::size_t n) {
    parent_.resize(n);
    std::iota(parent_.begin(), parent_.end(), std::size_t{0});
  }

  /// The representative of x's set (the smallest member ever united as a root: deterministic).
  std::size_t find(std::size_t x) {
    while (parent_[x] != x) x = parent_[x] = parent_[parent_[x]];
    return x;
  }
  /// Joins the sets of a and b; false when they were one set already.
  bool unite(std::size_t a, std::size_t b) {
    a = find(a);
    b = find(b);
    if (a == b) return false;
    if (a < b)
      parent_[b] = a;
    else
      parent_[a] = b;
    return true;
  }
  std::size_t size() const { return parent_.size(); }

 private:
  std::vector<std::size_t> parent_;
};

}  // namespace autoscan
