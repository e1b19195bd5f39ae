#include "autoscan/eval/metrics.hpp"

#include <fmt/format.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <sstream>

#include "autoscan/core/atomic_file.hpp"
#include "autoscan/core/error.hpp"
#include "autoscan/core/html.hpp"
#include "autoscan/core/random.hpp"
#include "autoscan/core/timer.hpp"
#include "autoscan/eval/mesh_distance.hpp"
#include "autoscan/shapes/sampling.hpp"
#include "autoscan/spatial/kdtree.hpp"

namespace autoscan::eval {

void EvalOptions::validate(const std::string& what) const { schema::check(*this, what); }

namespace {

double truth_diagonal(const TriangleMesh& truth) {
  AUTOSCAN_REQUIRE(!truth.faces.empty(), "evaluate: the truth mesh has no faces");
  const double d = truth.bounds().diagonal();
  AUTOSCAN_REQUIRE(std::isfinite(d) && d > 0, "evaluate: the truth mesh's bounding box is degenerate");
  return d;
}

double share_within(const std::vector<double>& d, double t) {
  if (d.empty()) return 0;
  const auto n = std::count_if(d.begin(), d.end(), [t](double x) { return x <= t; });
  return static_cast<double>(n) / static_cast<double>(d.size());
}

double fscore(double p, double r) { return p + r > 0 ? 2 * p * r / (p + r) : 0.0; }

// Distance from each query to its nearest point of `cloud` (kd-tree, parallel queries).
std::vector<double> nearest_point_distances(const std::vector<Vec3>& cloud, const std::vector<Vec3>& queries) {
  std::vector<double> out(queries.size(), std::numeric_limits<double>::infinity());
  if (cloud.empty()) return out;
  const spatial::KdTree tree(cloud, 16);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 1024), [&](const auto& r) {
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      double d2 = 0;
      tree.nearest(queries[i], &d2);
      out[i] = std::sqrt(d2);
    }
  });
  return out;
}

PointCloud sample(const TriangleMesh& m, std::size_t n, std::uint64_t seed, std::uint64_t stream) {
  Rng rng = Rng(seed).stream(stream);
  return sample_surface(m, n, rng);
}

}  // namespace

DistanceStats distance_stats(std::vector<double> d) {
  DistanceStats s;
  s.count = d.size();
  if (d.empty()) return s;
  std::sort(d.begin(), d.end());
  double sum = 0, sum2 = 0;
  for (double x : d) {
    sum += x;
    sum2 += x * x;
  }
  const double n = static_cast<double>(d.size());
  s.mean = sum / n;
  s.rms = std::sqrt(sum2 / n);
  auto pct = [&](double q) {
    const double pos = q * (n - 1);
    const auto lo = static_cast<std::size_t>(std::floor(pos));
    const std::size_t hi = std::min(lo + 1, d.size() - 1);
    return d[lo] + (pos - static_cast<double>(lo)) * (d[hi] - d[lo]);
  };
  s.median = pct(0.5);
  s.p90 = pct(0.9);
  s.p99 = pct(0.99);
  s.max = d.back();
  return s;
}

nlohmann::json DistanceStats::to_json() const {
  return {{"count", count}, {"mean", mean}, {"rms", rms}, {"median", median}, {"p90", p90}, {"p99", p99}, {"max", max}};
}

ErrorHistogram make_histogram(const std::vector<double>& distances, int bins, double max_distance, double diagonal) {
  AUTOSCAN_REQUIRE(bins >= 1, "histogram: bins must be at least 1 (got {})", bins);
  AUTOSCAN_REQUIRE(max_distance > 0 && diagonal > 0, "histogram: range and diagonal must be positive");
  ErrorHistogram h;
  h.diagonal = diagonal;
  const double top = max_distance * diagonal, width = top / bins;
  for (int b = 0; b <= bins; ++b) h.edges.push_back(width * b);
  h.counts.assign(static_cast<std::size_t>(bins), 0);
  for (double d : distances) {
    const double b = std::floor(d / width);
    if (!(b < bins)) {  // also NaN / inf
      ++h.overflow_count;
    } else {
      ++h.counts[static_cast<std::size_t>(std::max(0.0, b))];
    }
  }
  const double n = distances.empty() ? 1.0 : static_cast<double>(distances.size());
  for (auto c : h.counts) h.share.push_back(static_cast<double>(c) / n);
  h.overflow = static_cast<double>(h.overflow_count) / n;
  return h;
}

ErrorHistogram make_log_histogram(const std::vector<double>& distances, int bins, double max_distance,
                                  double diagonal) {
  AUTOSCAN_REQUIRE(bins >= 2, "log histogram: bins must be at least 2 (got {})", bins);
  AUTOSCAN_REQUIRE(max_distance > 0 && diagonal > 0, "log histogram: range and diagonal must be positive");
  ErrorHistogram h;
  h.diagonal = diagonal;
  const double top = max_distance * diagonal, low = top * 1e-3;
  h.edges.push_back(0.0);
  for (int b = 1; b <= bins; ++b) h.edges.push_back(low * std::pow(1e3, static_cast<double>(b - 1) / (bins - 1)));
  h.edges.back() = top;
  h.counts.assign(static_cast<std::size_t>(bins), 0);
  for (double d : distances) {
    if (!(d < top)) {  // also NaN / inf
      ++h.overflow_count;
      continue;
    }
    const auto it = std::upper_bound(h.edges.begin(), h.edges.end(), d);
    ++h.counts[static_cast<std::size_t>(std::max<std::ptrdiff_t>(1, it - h.edges.begin()) - 1)];
  }
  const double n = distances.empty() ? 1.0 : static_cast<double>(distances.size());
  for (auto c : h.counts) h.share.push_back(static_cast<double>(c) / n);
  h.overflow = static_cast<double>(h.overflow_count) / n;
  return h;
}

nlohmann::json ErrorHistogram::to_json() const {
  // labels (each bin's upper edge as a fraction of the diagonal) and values (= share): the report's plot.
  std::vector<std::string> labels;
  for (std::size_t b = 1; b < edges.size(); ++b) labels.push_back(fmt::format("{:.3g}", edges[b] / diagonal));
  return {{"edges", edges},
          {"share", share},
          {"counts", counts},
          {"overflow", overflow},
          {"overflow_count", overflow_count},
          {"diagonal", diagonal},
          {"labels", labels},
          {"values", share}};
}

nlohmann::json EvalResult::to_json() const {
  return {{"accuracy", accuracy.to_json()},
          {"completeness", completeness.to_json()},
          {"precision", precision},
          {"recall", recall},
          {"fscore", fscore},
          {"tau", tau},
          {"tau_abs", tau_abs},
          {"truth_diagonal", truth_diagonal},
          {"histogram", histogram.to_json()},
          {"log_histogram", log_histogram.to_json()},
          {"recon_faces", recon_faces},
          {"truth_faces", truth_faces},
          {"seconds", seconds}};
}

nlohmann::json CloudEvalResult::to_json() const {
  return {{"accuracy", accuracy.to_json()},
          {"precision", precision},
          {"coverage", coverage},
          {"fscore", fscore},
          {"tau", tau},
          {"tau_abs", tau_abs},
          {"truth_diagonal", truth_diagonal},
          {"histogram", histogram.to_json()},
          {"points", points},
          {"seconds", seconds}};
}

EvalResult evaluate_mesh(const TriangleMesh& recon, const TriangleMesh& truth, const EvalOptions& options) {
  options.validate();
  Stopwatch sw;
  EvalResult r;
  r.truth_diagonal = truth_diagonal(truth);
  AUTOSCAN_REQUIRE(!recon.faces.empty(), "evaluate: the reconstructed mesh has no faces");
  r.tau = options.tau;
  r.tau_abs = options.tau * r.truth_diagonal;
  r.recon_faces = recon.faces.size();
  r.truth_faces = truth.faces.size();

  const MeshDistance to_truth(truth, "truth mesh");
  const MeshDistance to_recon(recon, "reconstructed mesh");
  const PointCloud truth_samples = sample(truth, options.samples, options.seed, 0);
  const PointCloud recon_samples = sample(recon, options.samples, options.seed, 1);
  const std::vector<double> acc = to_truth.distances(recon_samples.positions);
  const std::vector<double> comp = to_recon.distances(truth_samples.positions);

  r.precision = share_within(acc, r.tau_abs);
  r.recall = share_within(comp, r.tau_abs);
  r.fscore = fscore(r.precision, r.recall);
  r.histogram = make_histogram(acc, options.histogram_bins, options.histogram_max, r.truth_diagonal);
  r.log_histogram =
      make_log_histogram(acc, std::max(2, options.histogram_bins), options.histogram_max, r.truth_diagonal);
  r.accuracy = distance_stats(acc);
  r.completeness = distance_stats(comp);
  r.seconds = sw.seconds();
  return r;
}

CloudEvalResult evaluate_cloud(const PointCloud& cloud, const TriangleMesh& truth, const EvalOptions& options) {
  options.validate();
  Stopwatch sw;
  CloudEvalResult r;
  r.truth_diagonal = truth_diagonal(truth);
  cloud.validate("evaluated point cloud");
  r.tau = options.tau;
  r.tau_abs = options.tau * r.truth_diagonal;
  r.points = cloud.size();
  const MeshDistance to_truth(truth, "truth mesh");
  const std::vector<double> acc = to_truth.distances(cloud.positions);
  r.precision = share_within(acc, r.tau_abs);
  const PointCloud truth_samples = sample(truth, options.samples, options.seed, 0);
  r.coverage = share_within(nearest_point_distances(cloud.positions, truth_samples.positions), r.tau_abs);
  r.fscore = fscore(r.precision, r.coverage);
  r.histogram = make_histogram(acc, options.histogram_bins, options.histogram_max, r.truth_diagonal);
  r.accuracy = distance_stats(acc);
  r.seconds = sw.seconds();
  return r;
}

double coverage(const PointCloud& scanned, const TriangleMesh& truth, double tau, std::size_t samples,
                std::uint64_t seed) {
  return CoverageProbe(truth, nullptr, tau, samples, seed).measure(scanned).coverage;
}

CoverageSplit coverage_split(const PointCloud& scanned, const PointCloud& reference, const TriangleMesh& truth,
                             double tau, std::size_t samples, std::uint64_t seed) {
  return CoverageProbe(truth, &reference, tau, samples, seed).measure(scanned);
}

CoverageProbe::CoverageProbe(const TriangleMesh& truth, const PointCloud* reference, double tau, std::size_t samples,
                             std::uint64_t seed) {
  EvalOptions o;
  o.tau = tau;
  o.samples = samples;
  o.validate();
  tau_abs_ = tau * truth_diagonal(truth);
  samples_ = sample(truth, samples, seed, 0).positions;  // the samples of coverage() and coverage_split()
  scannable_.assign(samples_.size(), 1);
  scannable_count_ = samples_.size();
  if (reference) {
    reference->validate("scannable reference cloud");
    const auto dr = nearest_point_distances(reference->positions, samples_);
    scannable_count_ = 0;
    for (std::size_t i = 0; i < dr.size(); ++i) {
      scannable_[i] = dr[i] <= tau_abs_ ? 1 : 0;
      scannable_count_ += scannable_[i];
    }
  }
}

CoverageSplit CoverageProbe::measure(const PointCloud& scanned) const {
  scanned.validate("scanned point cloud");
  CoverageSplit out;
  const double n = static_cast<double>(samples_.size());
  out.scannable_share = static_cast<double>(scannable_count_) / n;
  out.scannable_coverage = scannable_count_ ? 0.0 : 1.0;
  if (scanned.empty()) return out;
  const auto ds = nearest_point_distances(scanned.positions, samples_);
  std::size_t covered = 0, both = 0;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const bool c = ds[i] <= tau_abs_;
    covered += c;
    both += c && scannable_[i];
  }
  out.coverage = static_cast<double>(covered) / n;
  if (scannable_count_) out.scannable_coverage = static_cast<double>(both) / static_cast<double>(scannable_count_);
  return out;
}

std::vector<std::uint32_t> CoverageProbe::covered(const PointCloud& scanned) const {
  scanned.validate("scanned point cloud");
  std::vector<std::uint32_t> out;
  if (scanned.empty()) return out;
  const auto ds = nearest_point_distances(scanned.positions, samples_);
  for (std::size_t i = 0; i < ds.size(); ++i)
    if (ds[i] <= tau_abs_) out.push_back(static_cast<std::uint32_t>(i));
  return out;
}

void write_histogram_csv(const std::filesystem::path& path, const ErrorHistogram& h) {
  AUTOSCAN_REQUIRE(h.edges.size() == h.share.size() + 1 && h.counts.size() == h.share.size(),
                   "{}: inconsistent histogram", path.string());
  std::string text = "bin_lo,bin_hi,share,count\n";
  for (std::size_t b = 0; b < h.share.size(); ++b)
    text += fmt::format("{},{},{},{}\n", h.edges[b], h.edges[b + 1], h.share[b], h.counts[b]);
  text += fmt::format("{},inf,{},{}\n", h.edges.back(), h.overflow, h.overflow_count);
  write_text_atomic(path, text);
}

void write_histogram_svg(const std::filesystem::path& path,
                         const std::vector<std::pair<std::string, ErrorHistogram>>& series, const std::string& title) {
  AUTOSCAN_REQUIRE(!series.empty(), "{}: no histogram to draw", path.string());
  const ErrorHistogram& first = series.front().second;
  const std::size_t bins = first.share.size();
  AUTOSCAN_REQUIRE(bins > 0 && first.edges.size() == bins + 1, "{}: inconsistent histogram", path.string());
  for (const auto& [name, h] : series)
    AUTOSCAN_REQUIRE(h.edges == first.edges && h.share.size() == bins,
                     "{}: histogram '{}' has different bins from '{}'", path.string(), name, series.front().first);
  double top = 0;
  for (const auto& [name, h] : series)
    for (double s : h.share) top = std::max(top, s);
  top = std::max(0.05, std::ceil(top * 20.0) / 20.0);  // round up to 5 %

  const double W = 760, H = 420, left = 64, right = 16, up = 40, down = 70;
  const double pw = W - left - right, ph = H - up - down;
  static const char* palette[] = {"#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd",
                                  "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf"};
  std::ostringstream o;
  o << fmt::format(R"(<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" viewBox="0 0 {} {}" )"
                   R"(font-family="sans-serif" font-size="11">)"
                   "\n",
                   W, H, W, H);
  o << fmt::format(R"(<rect width="{}" height="{}" fill="white"/>)"
                   "\n",
                   W, H);
  o << fmt::format(R"(<text x="{}" y="22" text-anchor="middle" font-size="14">{}</text>)"
                   "\n",
                   W / 2, escape_html(title));
  // Y grid and labels.
  for (int t = 0; t <= 5; ++t) {
    const double v = top * t / 5, y = up + ph * (1 - v / top);
    o << fmt::format(R"(<line x1="{}" y1="{:.1f}" x2="{}" y2="{:.1f}" stroke="#ddd"/>)"
                     "\n",
                     left, y, left + pw, y);
    o << fmt::format(R"(<text x="{}" y="{:.1f}" text-anchor="end">{:.0f}%</text>)"
                     "\n",
                     left - 6, y + 4, 100 * v);
  }
  const double group = pw / static_cast<double>(bins);
  const double bar = group * 0.8 / static_cast<double>(series.size());
  for (std::size_t si = 0; si < series.size(); ++si) {
    const auto& h = series[si].second;
    for (std::size_t b = 0; b < bins; ++b) {
      const double x = left + group * static_cast<double>(b) + group * 0.1 + bar * static_cast<double>(si);
      const double hh = ph * h.share[b] / top;
      o << fmt::format(
          R"(<rect x="{:.1f}" y="{:.1f}" width="{:.1f}" height="{:.1f}" fill="{}"><title>{}: {:.2f}%</title></rect>)"
          "\n",
          x, up + ph - hh, bar, hh, palette[si % 10], escape_html(series[si].first), 100 * h.share[b]);
    }
  }
  // X labels: bin edges as a fraction of the diagonal (every other edge when crowded).
  const std::size_t every = bins > 12 ? (bins + 11) / 12 : 1;
  for (std::size_t b = 0; b <= bins; b += every) {
    const double x = left + group * static_cast<double>(b);
    o << fmt::format(R"(<text x="{:.1f}" y="{}" text-anchor="middle">{:.4g}</text>)"
                     "\n",
                     x, up + ph + 16, first.edges[b] / first.diagonal);
  }
  o << fmt::format(R"(<line x1="{}" y1="{}" x2="{}" y2="{}" stroke="black"/>)"
                   "\n",
                   left, up + ph, left + pw, up + ph);
  o << fmt::format(
      R"(<text x="{}" y="{}" text-anchor="middle">distance to the ground truth (fraction of the bounding-box diagonal)</text>)"
      "\n",
      left + pw / 2, up + ph + 36);
  o << fmt::format(
      "<text x=\"16\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">share of samples</text>"
      "\n",
      up + ph / 2, up + ph / 2);
  // Legend (with the overflow share).
  for (std::size_t si = 0; si < series.size(); ++si) {
    const double x = left + 8 + 170 * static_cast<double>(si % 4), y = H - 18 + 0 * static_cast<double>(si / 4);
    o << fmt::format(R"(<rect x="{:.1f}" y="{:.1f}" width="10" height="10" fill="{}"/>)"
                     "\n",
                     x, y - 9 - 14.0 * static_cast<double>(si / 4), palette[si % 10]);
    o << fmt::format(R"(<text x="{:.1f}" y="{:.1f}">{} (beyond: {:.1f}%)</text>)"
                     "\n",
                     x + 14, y - 14.0 * static_cast<double>(si / 4), escape_html(series[si].first),
                     100 * series[si].second.overflow);
  }
  o << "</svg>\n";
  write_text_atomic(path, o.str());
}

void write_histogram_svg(const std::filesystem::path& path, const ErrorHistogram& h, const std::string& title) {
  write_histogram_svg(path, {{"reconstruction", h}}, title);
}

ColorError color_error(const TriangleMesh& recon, const TriangleMesh& truth, double max_distance) {
  AUTOSCAN_REQUIRE(recon.vertex_colors.size() == recon.vertices.size() && !recon.vertices.empty(),
                   "colour error: the reconstruction has no vertex colours");
  AUTOSCAN_REQUIRE(truth.has_surface_colors(), "colour error: the truth has no colour");
  const MeshDistance md(truth, "truth");
  const double limit = max_distance * truth.bounds().diagonal();
  std::vector<double> err(recon.vertices.size(), -1.0);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, recon.vertices.size()),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      for (std::size_t v = r.begin(); v != r.end(); ++v) {
                        const ClosestPoint c = md.closest(recon.vertices[v]);
                        if (c.face < 0 || c.distance > limit) continue;
                        const Tri& t = truth.faces[static_cast<std::size_t>(c.face)];
                        const Vec3 a = truth.vertices[static_cast<std::size_t>(t[0])];
                        const Vec3 e1 = truth.vertices[static_cast<std::size_t>(t[1])] - a;
                        const Vec3 e2 = truth.vertices[static_cast<std::size_t>(t[2])] - a;
                        const Vec3 d = c.point - a;
                        const double d00 = e1.dot(e1), d01 = e1.dot(e2), d11 = e2.dot(e2);
                        const double den = d00 * d11 - d01 * d01;
                        double b1 = 0.0, b2 = 0.0;
                        if (std::abs(den) > 0.0) {
                          b1 = std::clamp((d11 * d.dot(e1) - d01 * d.dot(e2)) / den, 0.0, 1.0);
                          b2 = std::clamp((d00 * d.dot(e2) - d01 * d.dot(e1)) / den, 0.0, 1.0 - b1);
                        }
                        const Vec3 want = truth.color_at(static_cast<std::size_t>(c.face), b1, b2);
                        const Rgb& got = recon.vertex_colors[v];
                        err[v] = (Vec3(got[0], got[1], got[2]) - want).norm();
                      }
                    });
  std::vector<double> kept;
  kept.reserve(err.size());
  for (double e : err)
    if (e >= 0.0) kept.push_back(e);
  ColorError out;
  out.vertices = kept.size();
  out.counted_share = static_cast<double>(kept.size()) / static_cast<double>(recon.vertices.size());
  if (kept.empty()) return out;
  double sum = 0.0;
  for (double e : kept) sum += e;
  out.mean = sum / static_cast<double>(kept.size());
  std::sort(kept.begin(), kept.end());
  out.median = kept[kept.size() / 2];
  out.p90 = kept[static_cast<std::size_t>(0.9 * static_cast<double>(kept.size() - 1))];
  return out;
}

}  // namespace autoscan::eval
