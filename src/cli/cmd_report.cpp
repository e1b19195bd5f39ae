// autoscan report DIR — writes DIR/report.html for a session directory.
#include <memory>
#include <nlohmann/json.hpp>

#include "autoscan/report/report.hpp"
#include "command.hpp"

namespace {
struct ReportCli {
  std::string dir;
  autoscan::report::ReportOptions options;
};
}  // namespace

AUTOSCAN_CLI_COMMAND(report, 120, [](CLI::App& root, autoscan::cli::Globals& g) {
  auto opts = std::make_shared<ReportCli>();
  auto* sub = root.add_subcommand("report", "Write DIR/report.html: an offline 3D viewer and plots of a session");
  sub->add_option("dir", opts->dir, "Session directory (from simulate, demo or session init)")->required();
  sub->add_option("--max-points", opts->options.max_points, "Display budget per iteration's point cloud")
      ->capture_default_str();
  sub->add_option("--title", opts->options.title, "Page title (default: the directory name)");
  g.on_run(sub, [opts, &g] {
    namespace fs = std::filesystem;
    std::error_code ec;
    AUTOSCAN_REQUIRE(fs::is_directory(opts->dir, ec), "{}: not a directory", opts->dir);
    const auto r = autoscan::report::write_report(opts->dir, opts->options);
    g.emit({{"report", r.html.string()},
            {"iterations", r.iterations},
            {"points_shown", r.points_shown},
            {"bytes", r.bytes}});
    if (!g.json) fmt::print("report: {}\n", fs::absolute(r.html).string());
  });
});
