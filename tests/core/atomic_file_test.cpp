#include "dofcache/core/atomic_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "dofcache/core/error.h"
#include "scratch_dir.h"

namespace dofcache {
namespace {

namespace fs = std::filesystem;

class AtomicFile : public testing::ScratchDirTest {
 protected:
  std::vector<std::string> listing() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir_)) names.push_back(e.path().filename().string());
    std::sort(names.begin(), names.end());
    return names;
  }
  std::string contents(const std::string& file) const {
    std::ifstream in(file);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  }
};

TEST_F(AtomicFile, WritesThroughATemporaryAndRenames) {
  const std::string file = path("out.txt");
  std::string seen;
  write_atomically(file, [&](const std::string& tmp) {
    seen = tmp;
    EXPECT_FALSE(fs::exists(file));
    std::ofstream(tmp) << "hello";
  });
  EXPECT_NE(seen, file);
  EXPECT_EQ(contents(file), "hello");
  EXPECT_EQ(listing(), std::vector<std::string>{"out.txt"});
}

TEST_F(AtomicFile, FailedWriteRemovesTheTemporaryAndKeepsTheTarget) {
  const std::string file = path("keep.txt");
  std::ofstream(file) << "original";
  EXPECT_THROW(write_atomically(file,
                                [](const std::string& tmp) {
                                  std::ofstream(tmp) << "partial";
                                  throw Error("disk full");
                                }),
               Error);
  EXPECT_EQ(listing(), std::vector<std::string>{"keep.txt"});
  EXPECT_EQ(contents(file), "original");
}

TEST_F(AtomicFile, TemporaryPathsShareDirectoryAndExtension) {
  const std::string file = path("render.exr");
  std::string a = temporary_path_for(file), b = temporary_path_for(file);
  EXPECT_NE(a, b);
  EXPECT_EQ(fs::path(a).parent_path(), dir_);
  EXPECT_EQ(fs::path(a).extension(), ".exr");
  EXPECT_EQ(fs::path(a).filename().string().rfind(".render.tmp-", 0), 0u) << a;
  EXPECT_EQ(fs::path(temporary_path_for("plain.png")).parent_path(), fs::path());
}

TEST_F(AtomicFile, FailedRenameIsAOneLineError) {
  const std::string tmp = temporary_path_for(path("a.txt"));
  try {
    commit_temporary(tmp, path("a.txt"));  // the temporary does not exist
    FAIL() << "no error";
  } catch (const Error& e) {
    std::string msg = e.what();
    EXPECT_NE(msg.find("cannot write '" + path("a.txt") + "'"), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
  }
}

TEST_F(AtomicFile, BytesAreWrittenWholeWithEmbeddedZerosAndReplaceTheTarget) {
  const std::string file = path("data.bin");
  std::ofstream(file) << "an older, longer content";
  const std::string bytes("a\0b\nc", 5);
  write_bytes_atomically(file, bytes);
  EXPECT_EQ(contents(file), bytes);
  EXPECT_EQ(listing(), std::vector<std::string>{"data.bin"});
}

TEST_F(AtomicFile, ExecutableBytesAreExecutableForEveryoneAndRegularOnesAreNot) {
  const std::string script = path("run.sh"), text = path("plan.json");
  write_bytes_atomically(script, "#!/bin/sh\n", FileMode::Executable);
  write_bytes_atomically(text, "{}");
  const fs::perms exec = fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec;
  EXPECT_EQ(fs::status(script).permissions() & exec, exec);
  EXPECT_EQ(fs::status(text).permissions() & exec, fs::perms::none);
  EXPECT_EQ(contents(script), "#!/bin/sh\n");
  EXPECT_EQ(listing(), (std::vector<std::string>{"plan.json", "run.sh"}));
}

TEST_F(AtomicFile, BytesIntoAMissingDirectoryAreAOneLineErrorAndLeaveNothing) {
  const std::string file = path("missing/out.json");
  try {
    write_bytes_atomically(file, "{}");
    FAIL() << "no error";
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg, "cannot write '" + file + "'");
  }
  EXPECT_TRUE(listing().empty());
}

TEST_F(AtomicFile, StaleTemporariesOfDeadProcessesAreRemoved) {
  const std::string target = path("0001.exr");
  // A process id that cannot exist (above the kernel's pid_max limit of 2^22).
  const std::string dead = path(".0001.tmp-99999999-0.exr");
  const std::string alive = path(".0001.tmp-" + std::to_string(::getpid()) + "-5.exr");
  const std::string other = path(".0002.tmp-99999999-0.exr");  // not a target's
  const std::string unrelated = path("notes.tmp-1.txt");
  for (const std::string& f : {dead, alive, other, unrelated}) std::ofstream(f) << "x";
  remove_stale_temporaries({target, ""});
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(alive));
  EXPECT_TRUE(fs::exists(other));
  EXPECT_TRUE(fs::exists(unrelated));
}

TEST_F(AtomicFile, StaleTemporaryCleanupIgnoresMissingDirectories) {
  EXPECT_NO_THROW(remove_stale_temporaries({path("missing/0001.exr")}));
}

}  // namespace
}  // namespace dofcache
