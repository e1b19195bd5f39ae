#include <gtest/gtest.h>

#include "cli_util.hpp"

using autoscan::testing::run_cli;

TEST(Cli, HelpListsCommandsAndExitsZero) {
  const auto r = run_cli("--help");
  EXPECT_EQ(r.code, 0);
  EXPECT_NE(r.out.find("autoscan"), std::string::npos);
}

TEST(Cli, UnknownCommandIsUsageError) {
  const auto r = run_cli("no-such-command");
  EXPECT_EQ(r.code, 2);
}
