// SPDX-License-Identifier: Apache-2.0
// BackgroundWriter: what a loop appends reaches the file whole and in order; a writer held up
// by its file (a pipe nobody reads: the disk stalled) makes appends drop and count, never wait.
#include "rt/background_writer.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>

namespace rtm {
namespace {

struct TempFolder {
  std::string path;
  TempFolder() {
    char pattern[] = "/tmp/rtm-bgw-XXXXXX";
    path = mkdtemp(pattern);
  }
  ~TempFolder() { std::system(("rm -rf '" + path + "'").c_str()); }
};

std::string read_all(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(BackgroundWriter, WhatIsAppendedReachesTheFileWholeAndInOrderAcrossManyBuffers) {
  TempFolder dir;
  const std::string path = dir.path + "/log.csv";
  std::string expected;
  {
    BackgroundWriter writer(path, 4096);
    for (int i = 0; i < 20000; ++i) {
      const std::string row = std::to_string(i) + ",0.125,-3.5\n";
      // A patient appender: a row refused (the writer busy) is appended again after a flush.
      while (!writer.append(row)) writer.flush();
      expected += row;
    }
    writer.flush();
    EXPECT_EQ(read_all(path), expected) << "after flush() everything appended is in the file";
    EXPECT_EQ(writer.error(), "");
  }
  EXPECT_EQ(read_all(path), expected);
  EXPECT_GT(expected.size(), 10u * 4096) << "many buffers were handed over";
}

TEST(BackgroundWriter, ATextLongerThanABufferIsDroppedAndCountedAndTheRestGoesOn) {
  TempFolder dir;
  const std::string path = dir.path + "/log.txt";
  {
    BackgroundWriter writer(path, 4096);
    EXPECT_TRUE(writer.append("a\n"));
    EXPECT_FALSE(writer.append(std::string(5000, 'x')));
    EXPECT_TRUE(writer.append("b\n"));
    EXPECT_EQ(writer.dropped(), 1u);
  }
  EXPECT_EQ(read_all(path), "a\nb\n");
}

TEST(BackgroundWriter, AWriterHeldUpByItsFileMakesAppendsDropNotWait) {
  TempFolder dir;
  const std::string path = dir.path + "/pipe";
  ASSERT_EQ(mkfifo(path.c_str(), 0600), 0);
  const int reader = open(path.c_str(), O_RDONLY | O_NONBLOCK);  // nobody reads it yet
  ASSERT_GE(reader, 0);
  std::size_t accepted = 0;
  std::size_t drained = 0;
  std::thread drain;
  {
    BackgroundWriter writer(path, 4096);
    const std::string row(100, 'r');
    // The pipe holds 64 KiB; then the writer blocks in write() with a buffer, one more is
    // handed over, the third fills: from there on every append is dropped, at once.
    for (int i = 0; i < 5000; ++i)
      if (writer.append(row)) accepted += row.size();
    const std::uint64_t dropped = writer.dropped();
    EXPECT_GT(dropped, 0u) << "the loop would have waited for the disk";
    EXPECT_EQ(accepted + dropped * row.size(), 5000u * row.size());
    // The pipe is read again: the writer drains, and the destructor's flush completes.
    drain = std::thread([reader, &drained] {
      fcntl(reader, F_SETFL, fcntl(reader, F_GETFL) & ~O_NONBLOCK);
      char buffer[8192];
      for (ssize_t n; (n = read(reader, buffer, sizeof buffer)) > 0;) drained += static_cast<std::size_t>(n);
    });
  }
  drain.join();  // the writer closed the pipe: EOF
  close(reader);
  EXPECT_EQ(drained, accepted) << "what was accepted is written, whole";
}

TEST(BackgroundWriter, AFileThatCannotBeOpenedIsAnErrorNamingIt) {
  try {
    BackgroundWriter writer("/nonexistent-folder/log.csv");
    FAIL() << "no exception";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent-folder/log.csv"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rtm
