#pragma once
// What every end-to-end test of the `dofcache` executable needs: a fresh temporary directory per
// test, running the executable with its streams captured, and the check that a failure is one
// clean line.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "scratch_dir.h"

namespace dofcache::testing {

struct CliResult {
  int exit_code;
  std::string out, err;
};


inline int count_lines(const std::string& s) {
  return static_cast<int>(std::count(s.begin(), s.end(), '\n'));
}

class CliTest : public ScratchDirTest {
 protected:
  // Runs `dofcache ARGS` with stdout and stderr captured in the test directory.
  CliResult run(const std::string& args) {
    std::string cmd = std::string(DOFCACHE_EXE) + " " + args + " >" + (dir_ / "stdout").string() +
                      " 2>" + (dir_ / "stderr").string();
    int status = std::system(cmd.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(dir_ / "stdout"),
            slurp(dir_ / "stderr")};
  }

  // A failure: the expected exit code (any non-zero if 0 is given), exactly one line on stderr
  // starting "dofcache: error:", mentioning `needle`.
  void expect_one_line_error(const CliResult& r, const std::string& needle,
                             int expected_exit = 0) {
    if (expected_exit != 0)
      EXPECT_EQ(r.exit_code, expected_exit) << r.err;
    else
      EXPECT_NE(r.exit_code, 0) << r.err;
    EXPECT_EQ(count_lines(r.err), 1) << r.err;
    EXPECT_EQ(r.err.rfind("dofcache: error:", 0), 0u) << r.err;
    EXPECT_NE(r.err.find(needle), std::string::npos) << "expected '" << needle << "' in: " << r.err;
  }
};

}  // namespace dofcache::testing
