// Ordering views into a scan path (paper §3/§5: "ordered into a sequence for the next scan path").
// Nearest neighbour from the current pose by Rig::travel_cost, then improved: exact (Held-Karp
// dynamic programme) for up to 10 views, otherwise 2-opt and or-opt moves evaluated on the whole
// path cost (travel costs need not be symmetric). The result is never longer than the
// nearest-neighbour order.
#include <algorithm>
#include <limits>
#include <numeric>

#include "autoscan/core/error.hpp"
#include "autoscan/nbv/nbv.hpp"

namespace autoscan::nbv {

namespace {

struct CostTable {
  std::size_t n = 0;
  bool has_start = false;
  std::vector<double> start;  ///< from the current pose to view i
  std::vector<double> c;      ///< view i -> view j, c[i*n+j]
  double operator()(std::size_t i, std::size_t j) const { return c[i * n + j]; }
  double length(const std::vector<std::size_t>& ord) const {
    if (ord.empty()) return 0.0;
    double L = has_start ? start[ord[0]] : 0.0;
    for (std::size_t t = 1; t < ord.size(); ++t) L += (*this)(ord[t - 1], ord[t]);
    return L;
  }
};

std::vector<std::size_t> nearest_neighbour(const CostTable& T) {
  std::vector<std::size_t> ord;
  std::vector<char> used(T.n, 0);
  std::size_t cur = 0;
  if (T.has_start) {
    cur = static_cast<std::size_t>(std::min_element(T.start.begin(), T.start.end()) - T.start.begin());
  }
  ord.push_back(cur);
  used[cur] = 1;
  while (ord.size() < T.n) {
    std::size_t nxt = T.n;
    double bc = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < T.n; ++j)
      if (!used[j] && T(cur, j) < bc) {
        bc = T(cur, j);
        nxt = j;
      }
    used[nxt] = 1;
    ord.push_back(nxt);
    cur = nxt;
  }
  return ord;
}

/// Held-Karp over open paths; without a start pose the path starts at view 0 (the caller's first).
std::vector<std::size_t> exact_order(const CostTable& T) {
  const std::size_t n = T.n;
  const std::size_t full = (std::size_t(1) << n);
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<double> dp(full * n, inf);
  std::vector<int> parent(full * n, -1);
  for (std::size_t i = 0; i < n; ++i) {
    if (!T.has_start && i != 0) continue;
    dp[(std::size_t(1) << i) * n + i] = T.has_start ? T.start[i] : 0.0;
  }
  for (std::size_t mask = 1; mask < full; ++mask)
    for (std::size_t last = 0; last < n; ++last) {
      const double cur = dp[mask * n + last];
      if (!(mask & (std::size_t(1) << last)) || cur == inf) continue;
      for (std::size_t j = 0; j < n; ++j) {
        if (mask & (std::size_t(1) << j)) continue;
        const std::size_t m2 = mask | (std::size_t(1) << j);
        const double c = cur + T(last, j);
        if (c < dp[m2 * n + j]) {
          dp[m2 * n + j] = c;
          parent[m2 * n + j] = static_cast<int>(last);
        }
      }
    }
  std::size_t last = 0;
  double best = inf;
  for (std::size_t i = 0; i < n; ++i)
    if (dp[(full - 1) * n + i] < best) {
      best = dp[(full - 1) * n + i];
      last = i;
    }
  std::vector<std::size_t> ord;
  std::size_t mask = full - 1;
  int cur = static_cast<int>(last);
  while (cur >= 0) {
    ord.push_back(static_cast<std::size_t>(cur));
    const int p = parent[mask * n + static_cast<std::size_t>(cur)];
    mask &= ~(std::size_t(1) << cur);
    cur = p;
  }
  std::reverse(ord.begin(), ord.end());
  return ord;
}

void local_search(const CostTable& T, std::vector<std::size_t>& ord) {
  const std::size_t n = ord.size();
  const std::size_t first = T.has_start ? 0 : 1;  // without a start pose the first view stays first
  double L = T.length(ord);
  bool improved = true;
  for (int pass = 0; improved && pass < 100; ++pass) {
    improved = false;
    // 2-opt: reverse ord[i..j].
    for (std::size_t i = first; i + 1 < n; ++i)
      for (std::size_t j = i + 1; j < n; ++j) {
        std::reverse(ord.begin() + static_cast<std::ptrdiff_t>(i), ord.begin() + static_cast<std::ptrdiff_t>(j) + 1);
        const double L2 = T.length(ord);
        if (L2 < L - 1e-12) {
          L = L2;
          improved = true;
        } else {
          std::reverse(ord.begin() + static_cast<std::ptrdiff_t>(i), ord.begin() + static_cast<std::ptrdiff_t>(j) + 1);
        }
      }
    // or-opt: move one view elsewhere.
    for (std::size_t i = first; i < n; ++i)
      for (std::size_t j = first; j < n; ++j) {
        if (i == j) continue;
        auto trial = ord;
        const std::size_t x = trial[i];
        trial.erase(trial.begin() + static_cast<std::ptrdiff_t>(i));
        trial.insert(trial.begin() + static_cast<std::ptrdiff_t>(j), x);
        const double L2 = T.length(trial);
        if (L2 < L - 1e-12) {
          L = L2;
          ord = std::move(trial);
          improved = true;
        }
      }
  }
}

}  // namespace

PathOrder order_path(const std::vector<Pose>& views, const std::optional<Pose>& from, const Rig& rig, bool optimize) {
  PathOrder out;
  if (views.empty()) return out;
  CostTable T;
  T.n = views.size();
  T.has_start = from.has_value();
  if (from) {
    from->validate("current pose");
    T.start.resize(T.n);
    for (std::size_t i = 0; i < T.n; ++i) T.start[i] = rig.travel_cost(*from, views[i]);
  }
  T.c.resize(T.n * T.n);
  for (std::size_t i = 0; i < T.n; ++i)
    for (std::size_t j = 0; j < T.n; ++j) T.c[i * T.n + j] = i == j ? 0.0 : rig.travel_cost(views[i], views[j]);
  std::vector<std::size_t> nn;
  if (T.has_start) {
    nn = nearest_neighbour(T);
  } else {
    // No current pose: start at the first view (the caller's best) and go greedily from there.
    CostTable T0 = T;
    T0.has_start = true;
    T0.start.assign(T.n, 1.0);
    T0.start[0] = 0.0;
    nn = nearest_neighbour(T0);
  }
  out.nn_length = T.length(nn);
  std::vector<std::size_t> ord = nn;
  if (optimize && T.n > 1) {
    if (T.n <= 10) {
      ord = exact_order(T);
    } else {
      local_search(T, ord);
    }
    if (T.length(ord) > out.nn_length) ord = nn;
  }
  out.order = ord;
  out.length = T.length(ord);
  return out;
}

}  // namespace autoscan::nbv
