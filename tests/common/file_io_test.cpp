// Reading inputs (engine/common/text_file.h: regular files only, never waiting on a FIFO) and
// writing outputs (engine/common/output_file.h: whole or not at all).
#include <sys/stat.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "engine/common/error.h"
#include "engine/common/output_file.h"
#include "engine/common/text_file.h"
#include "tests/support/temp_dir.h"

namespace machplan {
namespace {

using ::testing::HasSubstr;
namespace fs = std::filesystem;

std::string file_io_contents(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// What read_text_file threw for `path`, or "" when it read it.
std::string file_io_refusal(const std::string& path) {
  try {
    read_text_file(path);
  } catch (const InputError& e) {
    return e.what();
  }
  return {};
}

// The names in `dir`, one per line, sorted.
std::string file_io_listing(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  std::string s;
  for (const std::string& n : names) s += n + "\n";
  return s;
}

TEST(ReadTextFile, ReadsARegularFileWhole) {
  test::TempDir dir;
  const std::string bytes("G0 X1\n\0binary\xff", 14);
  EXPECT_EQ(read_text_file(dir.write("a.ngc", bytes)), bytes);
  EXPECT_EQ(read_text_file(dir.write("empty.ngc", "")), "");
}

// No writer ever opens the FIFO: a reader that waited for one would hang here.
TEST(ReadTextFile, RefusesAFifoWithoutWaitingForAWriter) {
  test::TempDir dir;
  const std::string fifo = (dir.path() / "pipe.ngc").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0) << std::strerror(errno);
  EXPECT_EQ(file_io_refusal(fifo),
            fifo + ": is a FIFO (named pipe), not a regular file; machplan reads input only from regular files");
}

TEST(ReadTextFile, RefusesADeviceAndAFolder) {
  test::TempDir dir;
  EXPECT_THAT(file_io_refusal("/dev/zero"), HasSubstr("/dev/zero: is a character device, not a regular file"));
  EXPECT_THAT(file_io_refusal("/dev/null"), HasSubstr("/dev/null: is a character device, not a regular file"));
  EXPECT_EQ(file_io_refusal(dir.path().string()), dir.path().string() + ": is a folder, expected a file");
  EXPECT_EQ(file_io_refusal((dir.path() / "none.ngc").string()),
            (dir.path() / "none.ngc").string() + ": cannot open file: no such file");
}

TEST(ReadTextFile, RefusesAFileOverTheLimitBeforeReadingIt) {
  test::TempDir dir;
  const std::string path = dir.write("big.ngc", std::string(100, 'x'));
  try {
    read_text_file(path, 99);
    FAIL() << "read";
  } catch (const InputError& e) {
    EXPECT_THAT(e.what(), HasSubstr("file is 100 bytes, more than the limit of 99 bytes"));
  }
}

TEST(AtomicOutput, CommitReplacesTheFileAndLeavesNothingBeside) {
  test::TempDir dir;
  const std::string path = dir.write("out.ngc", "old program\n");
  ::chmod(path.c_str(), 0640);
  write_file_atomically(path, "new program\n");
  EXPECT_EQ(file_io_contents(path), "new program\n");
  EXPECT_EQ(file_io_listing(dir.path()), "out.ngc\n");
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0640u);  // a file replaced keeps its permissions
}

TEST(AtomicOutput, ALinkKeepsPointingAtTheFileItNames) {
  test::TempDir dir;
  const std::string real = dir.write("real.ngc", "old\n");
  const fs::path link = dir.path() / "link.ngc";
  fs::create_symlink(real, link);
  write_file_atomically(link.string(), "new\n");
  EXPECT_TRUE(fs::is_symlink(link));
  EXPECT_EQ(file_io_contents(real), "new\n");
  EXPECT_EQ(file_io_listing(dir.path()), "link.ngc\nreal.ngc\n");
}

// A device has no content to keep and no folder of its own to hold a temporary: written
// straight through (and /dev stays as it was).
TEST(AtomicOutput, ADeviceIsWrittenStraightThrough) {
  const std::set<std::string> before = [] {
    std::set<std::string> names;
    for (const auto& e : fs::directory_iterator("/dev")) names.insert(e.path().filename().string());
    return names;
  }();
  write_file_atomically("/dev/null", "discarded\n");
  for (const auto& e : fs::directory_iterator("/dev"))
    EXPECT_TRUE(before.count(e.path().filename().string())) << e.path();
  EXPECT_TRUE(fs::is_character_file("/dev/null"));
  try {
    write_file_atomically("/dev/full", "no room\n");
    FAIL() << "written";
  } catch (const OutputError& e) {
    EXPECT_EQ(std::string(e.what()), std::string("/dev/full: cannot write: ") + std::strerror(ENOSPC));
  }
}

TEST(AtomicOutput, ANewFileGetsThePermissionsOfAPlainOpen) {
  test::TempDir dir;
  const mode_t mask = ::umask(022);
  const std::string path = (dir.path() / "new.csv").string();
  write_file_atomically(path, "a,b\n");
  ::umask(mask);
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0644u);
}

TEST(AtomicOutput, AWriterThatFailsLeavesTheOldFileAndNoTemporary) {
  test::TempDir dir;
  const std::string path = dir.write("out.ngc", "old program\n");
  {
    AtomicOutput out(path);
    out.write("half of a new pro");
    EXPECT_EQ(file_io_contents(path), "old program\n");  // nothing under the name until commit()
    // The writer stops with an exception: the temporary goes with the object.
  }
  EXPECT_EQ(file_io_contents(path), "old program\n");
  EXPECT_EQ(file_io_listing(dir.path()), "out.ngc\n");
  AtomicOutput out(path);
  out.write("a picture Cairo could not finish");
  out.fail("cannot draw the picture: out of memory");
  try {
    out.commit();
    FAIL() << "committed";
  } catch (const OutputError& e) {
    EXPECT_EQ(std::string(e.what()), path + ": cannot write: cannot draw the picture: out of memory");
    EXPECT_EQ(e.path(), path);
  }
  EXPECT_EQ(file_io_contents(path), "old program\n");
  EXPECT_EQ(file_io_listing(dir.path()), "out.ngc\n");
}

TEST(AtomicOutput, AFolderThatCannotBeWrittenIsAnOutputErrorWithTheSystemsReason) {
  test::TempDir dir;
  const std::string missing = (dir.path() / "no" / "such" / "out.ngc").string();
  try {
    write_file_atomically(missing, "x");
    FAIL() << "written";
  } catch (const OutputError& e) {
    EXPECT_EQ(std::string(e.what()), missing + ": cannot write: " + std::strerror(ENOENT));
  }
}

}  // namespace
}  // namespace machplan
