// SPDX-License-Identifier: Apache-2.0
// Shared-memory segments across real processes (fork): who may open one, what a killed
// process leaves behind, and the ring between two processes: no torn datum, a writer killed
// in the middle of a write, a reader that never reads.
#include "rt/shm_ring.h"
#include "rt/shm_segment.h"

#include <gtest/gtest.h>

#include <fcntl.h>
#include <sched.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <functional>
#include <grp.h>
#include <optional>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using rtm::ReadStatus;
using rtm::ShmRingReader;
using rtm::ShmRingShape;
using rtm::ShmRingWriter;
using rtm::ShmSegment;

constexpr std::uint64_t kType = 0xF00D;

std::int64_t now_ns() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return std::int64_t{ts.tv_sec} * 1'000'000'000 + ts.tv_nsec;
}

// A child process running body; its exit status is body's return value. Killed and reaped at
// scope exit when the test did not wait for it.
struct Child {
  pid_t pid = -1;
  explicit Child(const std::function<int()>& body) {
    pid = fork();
    if (pid == 0) {
      int code = 99;
      try {
        code = body();
      } catch (...) {
        code = 98;
      }
      _exit(code);
    }
  }
  Child(const Child&) = delete;
  Child& operator=(const Child&) = delete;
  int wait() {
    int status = 0;
    waitpid(pid, &status, 0);
    pid = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  }
  bool running() const {
    siginfo_t info{};
    return waitid(P_PID, static_cast<id_t>(pid), &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == 0;
  }
  void kill_and_wait() {
    ::kill(pid, SIGKILL);
    wait();
  }
  ~Child() {
    if (pid > 0) kill_and_wait();
  }
};

// A pipe to pass a line from a child to the test.
struct Pipe {
  int fds[2] = {-1, -1};
  Pipe() { EXPECT_EQ(pipe(fds), 0); }
  ~Pipe() {
    for (int fd : fds)
      if (fd >= 0) close(fd);
  }
  void send(const std::string& text) const { (void)!write(fds[1], text.data(), text.size() + 1); }
  std::string receive() const {
    std::string text;
    char c = 0;
    while (read(fds[0], &c, 1) == 1 && c != '\0') text += c;
    return text;
  }
};

// Each test has its own segment folder: XDG_RUNTIME_DIR is a fresh folder on /dev/shm.
class ShmSegmentTest : public ::testing::Test {
 protected:
  void SetUp() override {
    char tmpl[] = "/dev/shm/rtm-shm-test-XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr) << std::strerror(errno);
    runtime_ = tmpl;
    if (const char* old = std::getenv("XDG_RUNTIME_DIR")) saved_ = old;
    setenv("XDG_RUNTIME_DIR", runtime_.c_str(), 1);
  }
  void TearDown() override {
    if (saved_) setenv("XDG_RUNTIME_DIR", saved_->c_str(), 1);
    else unsetenv("XDG_RUNTIME_DIR");
    std::error_code ec;
    fs::remove_all(runtime_, ec);
  }
  static std::vector<std::string> files() {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(ShmSegment::folder())) names.push_back(e.path().filename());
    return names;
  }
  fs::path runtime_;
  std::optional<std::string> saved_;
};

TEST_F(ShmSegmentTest, ASegmentIsA0600FileInA0700FolderOfThisUserAndGoesWithItsMaker) {
  std::string name;
  {
    ShmSegment seg = ShmSegment::create(4096, "sensor0.out0");
    name = seg.name();
    EXPECT_TRUE(name.starts_with("ssensor0.out0.")) << name;
    EXPECT_EQ(ShmSegment::folder(), runtime_ / "rtm-shm");
    struct stat dir {}, file {};
    ASSERT_EQ(stat(ShmSegment::folder().c_str(), &dir), 0);
    ASSERT_EQ(stat((ShmSegment::folder() / name).c_str(), &file), 0);
    EXPECT_EQ(dir.st_mode & 0777, 0700U);
    EXPECT_EQ(file.st_mode & 0777, 0600U);
    EXPECT_EQ(file.st_uid, geteuid());
    EXPECT_EQ(file.st_size, 4096);
    // A reader of this user maps the same memory.
    ShmSegment other = ShmSegment::open(name);
    static_cast<char*>(seg.data())[100] = 'x';
    EXPECT_EQ(static_cast<char*>(other.data())[100], 'x');
    EXPECT_FALSE(other.owner());
  }
  EXPECT_FALSE(fs::exists(ShmSegment::folder() / name));
}

TEST_F(ShmSegmentTest, OpenTakesOnlyANameInTheFolderNeverAPath) {
  ShmSegment seg = ShmSegment::create(4096, "a");
  for (const std::string& bad : std::vector<std::string>{"../" + seg.name(), "/etc/passwd", "x/y.shm", ".hidden.shm", "", "a.txt",
                                "a b.shm"}) {
    EXPECT_THROW(ShmSegment::open(bad), std::runtime_error) << bad;
  }
  // A label with a path in it is flattened, not followed.
  ShmSegment flat = ShmSegment::create(4096, "../../etc/x");
  EXPECT_EQ(flat.name().find('/'), std::string::npos) << flat.name();
  EXPECT_TRUE(fs::exists(ShmSegment::folder() / flat.name()));
}

TEST_F(ShmSegmentTest, AFileOthersMayReadOrALinkIsNotMapped) {
  const fs::path dir = ShmSegment::folder();
  {
    const int fd = ::open((dir / "open.1.1.1.shm").c_str(), O_CREAT | O_RDWR, 0644);
    ASSERT_GE(fd, 0);
    ASSERT_EQ(fchmod(fd, 0644), 0);
    ASSERT_EQ(ftruncate(fd, 4096), 0);
    close(fd);
  }
  EXPECT_THROW(ShmSegment::open("open.1.1.1.shm"), std::runtime_error);
  fs::create_symlink(dir / "open.1.1.1.shm", dir / "link.1.1.1.shm");
  EXPECT_THROW(ShmSegment::open("link.1.1.1.shm"), std::runtime_error);
}

TEST_F(ShmSegmentTest, AFolderOthersMayEnterIsRefusedWithTheReason) {
  ASSERT_EQ(mkdir((runtime_ / "rtm-shm").c_str(), 0755), 0);
  ASSERT_EQ(chmod((runtime_ / "rtm-shm").c_str(), 0755), 0);
  try {
    ShmSegment::create(4096, "a");
    FAIL() << "a segment was made in a folder open to others";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("open to other users (mode 755)"), std::string::npos) << e.what();
  }
}

TEST_F(ShmSegmentTest, AFolderOfAnotherUserIsRefusedWithTheReason) {
  if (geteuid() != 0) GTEST_SKIP() << "giving a folder to another user needs root";
  ASSERT_EQ(mkdir((runtime_ / "rtm-shm").c_str(), 0700), 0);
  ASSERT_EQ(chown((runtime_ / "rtm-shm").c_str(), 65534, 65534), 0);
  try {
    ShmSegment::create(4096, "a");
    FAIL() << "a segment was made in another user's folder";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("belongs to uid 65534"), std::string::npos) << e.what();
  }
}

TEST_F(ShmSegmentTest, AnotherUserCanNeitherOpenASegmentNorPlantOne) {
  if (geteuid() != 0) GTEST_SKIP() << "acting as the user nobody needs root";
  ShmSegment seg = ShmSegment::create(4096, "sensor0.out0");
  const fs::path folder = ShmSegment::folder();
  const fs::path path = folder / seg.name();
  Child nobody([&] {
    if (setgroups(0, nullptr) != 0 || setresgid(65534, 65534, 65534) != 0 || setresuid(65534, 65534, 65534) != 0)
      return 10;
    if (::open(path.c_str(), O_RDONLY) >= 0) return 1;  // read the owner's data
    if (errno != EACCES) return 2;
    if (::open((folder / "planted.1.1.1.shm").c_str(), O_CREAT | O_RDWR, 0600) >= 0) return 3;
    return 0;
  });
  EXPECT_EQ(nobody.wait(), 0) << "1: opened the segment, 2: failed for another reason, 3: planted a file, 10: setuid";
}

TEST_F(ShmSegmentTest, SegmentsOfKilledProcessesAreGoneAfterTheNextCreate) {
  Pipe names;
  Child maker([&] {
    ShmSegment a = ShmSegment::create(4096, "killed.a");
    ShmSegment b = ShmSegment::create(4096, "killed.b");
    names.send(a.name() + "|" + b.name());
    pause();  // until killed: the destructors never run
    return 0;
  });
  const std::string both = names.receive();
  const auto bar = both.find('|');
  ASSERT_NE(bar, std::string::npos) << both;
  ShmSegment mine = ShmSegment::create(4096, "alive");  // maker still runs: its files stay
  EXPECT_TRUE(fs::exists(ShmSegment::folder() / both.substr(0, bar)));
  maker.kill_and_wait();
  EXPECT_TRUE(fs::exists(ShmSegment::folder() / both.substr(bar + 1)));
  ShmSegment next = ShmSegment::create(4096, "next");
  EXPECT_FALSE(fs::exists(ShmSegment::folder() / both.substr(0, bar)));
  EXPECT_FALSE(fs::exists(ShmSegment::folder() / both.substr(bar + 1)));
  EXPECT_TRUE(fs::exists(ShmSegment::folder() / mine.name()));  // a living maker's file stays
  EXPECT_TRUE(fs::exists(ShmSegment::folder() / next.name()));
}

// Another host is told apart by the kernel's boot id; a network namespace standing in for one
// (as the multi-host tests do) by the namespace: its processes keep CORBA.
TEST_F(ShmSegmentTest, AProcessInAnotherNetworkNamespaceHasAnotherHostIdentity) {
  const std::string here = rtm::shm_host_identity();
  EXPECT_NE(here.find("/net:"), std::string::npos) << here;
  auto identity_in_child = [](bool new_namespace) {
    Pipe out;
    Child child([&] {
      if (new_namespace && unshare(CLONE_NEWNET) != 0) return 1;
      out.send(rtm::shm_host_identity());
      return 0;
    });
    std::string text = out.receive();
    return child.wait() == 0 ? text : std::string("unshare failed");
  };
  EXPECT_EQ(identity_in_child(false), here) << "a plain child process shares the host";
  if (geteuid() != 0) GTEST_SKIP() << "a network namespace of its own needs root";
  const std::string other = identity_in_child(true);
  ASSERT_NE(other, "unshare failed");
  EXPECT_NE(other, here);
  EXPECT_EQ(other.substr(0, other.find('/')), here.substr(0, here.find('/'))) << "same kernel, same boot id";
}

// ----------------------------------------------------------------------------------------
// The ring between processes
// ----------------------------------------------------------------------------------------

// Datum n: its words all equal n, so a mix of two data shows.
template <std::size_t Words>
struct Pattern {
  std::array<std::uint64_t, Words> words;
  bool whole(std::uint64_t n) const {
    for (auto w : words)
      if (w != n) return false;
    return true;
  }
};

template <class T>
std::span<std::byte> writable(T& value) {
  return std::as_writable_bytes(std::span(&value, 1));
}

TEST_F(ShmSegmentTest, AReaderInAnotherProcessNeverKeepsATornDatum) {
  using P = Pattern<32>;
  const ShmRingShape shape{2, sizeof(P), kType};
  ShmSegment seg = ShmSegment::create(rtm::shm_ring_bytes(shape), "torn");
  ShmRingWriter writer(seg.data(), seg.size(), shape);
  constexpr std::uint64_t kData = 300'000;
  Pipe ready;
  Child reader_process([&] {
    ShmSegment mine = ShmSegment::open(seg.name());
    ShmRingReader reader(mine.data(), mine.size(), kType);
    ready.send("ready");
    P p{};
    std::uint64_t kept = 0, torn = 0, last = 0;
    while (last < kData) {
      const auto r = reader.take_latest(writable(p));
      if (r.status != ReadStatus::new_data) continue;
      if (!p.whole(r.number)) ++torn;
      last = r.number;
      ++kept;
    }
    return torn != 0 ? 1 : kept == 0 ? 2 : 0;
  });
  ASSERT_EQ(ready.receive(), "ready");
  P p{};
  for (std::uint64_t n = 1; n <= kData; ++n) {
    p.words.fill(n);
    writer.write(std::as_bytes(std::span(&p, 1)));
  }
  EXPECT_EQ(reader_process.wait(), 0) << "1: a torn datum was kept, 2: nothing was read";
}

TEST_F(ShmSegmentTest, AWriterKilledInTheMiddleOfAWriteLeavesTheLastWholeDatum) {
  using P = Pattern<65536>;  // 512 KiB: a write takes long enough to be killed inside one
  const ShmRingShape shape{2, sizeof(P), kType};
  int killed_mid_write = 0;
  for (int round = 0; round < 40 && killed_mid_write < 3; ++round) {
    ShmSegment seg = ShmSegment::create(rtm::shm_ring_bytes(shape), "killed");
    Child writer_process([&] {
      ShmRingWriter writer(seg.data(), seg.size(), shape);
      auto p = std::make_unique<P>();
      for (std::uint64_t n = 1;; ++n) {
        p->words.fill(n);
        writer.write(std::as_bytes(std::span(p.get(), 1)));
      }
      return 0;
    });
    // Wait for a ring, then for a write under way, and kill the writer there.
    std::optional<ShmRingReader> reader;
    while (!reader && writer_process.running()) {
      try {
        reader.emplace(seg.data(), seg.size(), kType);
      } catch (const std::runtime_error&) {
        sched_yield();
      }
    }
    ASSERT_TRUE(reader) << "the writer process ended before it made its ring";
    while ((reader->published() < 2 || !reader->write_in_progress()) && writer_process.running()) sched_yield();
    ASSERT_TRUE(writer_process.running()) << "the writer process ended by itself";
    writer_process.kill_and_wait();
    if (!reader->write_in_progress()) continue;  // the write ended before the signal: again
    ++killed_mid_write;
    auto p = std::make_unique<P>();
    const auto r = reader->take_latest(writable(*p));
    ASSERT_NE(r.status, ReadStatus::no_data);  // old_data when the reader came after it was written
    EXPECT_EQ(r.number, reader->published());
    EXPECT_TRUE(p->whole(r.number)) << "the datum kept after the writer died is torn";
  }
  EXPECT_GT(killed_mid_write, 0) << "no round killed the writer inside a write";
}

TEST_F(ShmSegmentTest, AReaderThatNeverReadsOrWaitsStoppedDoesNotHoldTheWriterBack) {
  const ShmRingShape shape{4, 8, kType};
  ShmSegment seg = ShmSegment::create(rtm::shm_ring_bytes(shape), "stopped");
  ShmRingWriter writer(seg.data(), seg.size(), shape);
  Pipe ready;
  // One reader waits for data and is stopped there (it stays registered as a waiter); the
  // writer still writes all it has, each write with its futex wake.
  Child waiter([&] {
    ShmSegment mine = ShmSegment::open(seg.name());
    ShmRingReader reader(mine.data(), mine.size(), kType);
    ready.send("ready");
    return reader.wait_for_data(now_ns() + 60'000'000'000) ? 0 : 1;
  });
  ASSERT_EQ(ready.receive(), "ready");
  ShmRingReader idle(seg.data(), seg.size(), kType);  // never reads until the end
  while (idle.waiting() == 0 && waiter.running()) sched_yield();
  ASSERT_EQ(idle.waiting(), 1U);
  ASSERT_EQ(::kill(waiter.pid, SIGSTOP), 0);
  for (std::uint64_t n = 1; n <= 100'000; ++n) writer.write(std::as_bytes(std::span(&n, 1)));
  EXPECT_EQ(writer.written(), 100'000U);
  std::uint64_t v = 0;
  const auto r = idle.take_next(writable(v));
  EXPECT_EQ(r.status, ReadStatus::new_data);
  EXPECT_EQ(r.missed, 100'000U - 3U);  // 4 slots: the newest 3 are still there
  EXPECT_EQ(v, 100'000U - 2U);
  ::kill(waiter.pid, SIGCONT);
  EXPECT_EQ(waiter.wait(), 0);
}

}  // namespace
