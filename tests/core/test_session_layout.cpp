// The session directory's paths (core/session_layout.hpp, docs/session-format.md), the one HTML/SVG
// escape (core/html.hpp), and the tests' temporary directories (tests/support/temp_dir.hpp).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "autoscan/core/html.hpp"
#include "autoscan/core/session_layout.hpp"
#include "support/temp_dir.hpp"

using autoscan::SessionLayout;
namespace fs = std::filesystem;

TEST(SessionLayout, NamesThePathsOfDocsSessionFormat) {
  const SessionLayout L("/data/run");
  EXPECT_EQ(L.session_json(), fs::path("/data/run/session.json"));
  EXPECT_EQ(L.model(), fs::path("/data/run/model.ply"));
  EXPECT_EQ(L.report(), fs::path("/data/run/report.html"));
  EXPECT_EQ(L.scan_ply(7), fs::path("/data/run/scans/scan_0007.ply"));
  EXPECT_EQ(L.scan_json(12345), fs::path("/data/run/scans/scan_12345.json"));
  EXPECT_EQ(SessionLayout::scan_file(3), "scans/scan_0003.ply");
  EXPECT_EQ(L.orphaned_dir(), fs::path("/data/run/scans/orphaned"));
  EXPECT_EQ(L.iteration_dir(0), fs::path("/data/run/iterations/iter_000"));
  EXPECT_EQ(L.iteration_dir(1234), fs::path("/data/run/iterations/iter_1234"));
  EXPECT_EQ(L.cloud(2), fs::path("/data/run/iterations/iter_002/cloud.ply"));
  EXPECT_EQ(L.consolidated(2), fs::path("/data/run/iterations/iter_002/consolidated.ply"));
  EXPECT_EQ(L.mesh(2), fs::path("/data/run/iterations/iter_002/mesh.ply"));
  EXPECT_EQ(L.mesh_color(2), fs::path("/data/run/iterations/iter_002/mesh_color.ply"));
  EXPECT_EQ(L.iso(2), fs::path("/data/run/iterations/iter_002/iso.ply"));
  EXPECT_EQ(L.views(2), fs::path("/data/run/iterations/iter_002/views.json"));
  EXPECT_EQ(L.field_slice(2), fs::path("/data/run/iterations/iter_002/field_slice.png"));
}

TEST(Html, EscapesTheFourMarkupCharactersOnly) {
  EXPECT_EQ(autoscan::escape_html(R"(<a href="x">&</a>)"), "&lt;a href=&quot;x&quot;&gt;&amp;&lt;/a&gt;");
  EXPECT_EQ(autoscan::escape_html("plain 'text' — é"), "plain 'text' — é");
  EXPECT_EQ(autoscan::escape_html(""), "");
}

TEST(TempDir, RemovesItsDirectoryAndContentAtTheEndOfItsScope) {
  fs::path where;
  {
    const autoscan::testing::TempDir dir("temp_dir_test");
    where = dir.path();
    EXPECT_TRUE(fs::is_directory(where));
    fs::create_directories(dir / "a" / "b");
    std::ofstream(dir / "a" / "b" / "f.txt") << "x";
  }
  EXPECT_FALSE(fs::exists(where));
  const fs::path s = autoscan::testing::scratch_dir("scratch_test");
  EXPECT_TRUE(fs::is_directory(s));
  EXPECT_EQ(s.parent_path(), autoscan::testing::scratch_root().path());
}
