// SPDX-License-Identifier: Apache-2.0
#include "rt/shm_segment.h"

#include <dirent.h>
#include <fcntl.h>
#include <linux/magic.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <sys/vfs.h>
#include <unistd.h>

#include <atomic>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace rtm {

namespace {

namespace fs = std::filesystem;

constexpr std::size_t kMaxSegmentBytes = std::size_t{256} << 20;
constexpr std::string_view kSuffix = ".shm";

std::string errno_text() { return std::strerror(errno); }

// A file descriptor closed at scope exit.
struct Fd {
  int fd = -1;
  explicit Fd(int f) : fd(f) {}
  Fd(const Fd&) = delete;
  Fd& operator=(const Fd&) = delete;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

bool on_tmpfs(const char* path) {
  struct statfs fs_info {};
  return ::statfs(path, &fs_info) == 0 && fs_info.f_type == TMPFS_MAGIC;
}

// A folder of this user's that nobody else may enter: made 0700 when missing; else checked.
void ensure_private_folder(const fs::path& dir) {
  if (::mkdir(dir.c_str(), 0700) != 0 && errno != EEXIST)
    throw std::runtime_error("cannot make " + dir.string() + " for shared-memory ports: " + errno_text());
  struct stat st {};
  if (::lstat(dir.c_str(), &st) != 0)
    throw std::runtime_error("cannot look at " + dir.string() + ": " + errno_text());
  if (!S_ISDIR(st.st_mode))
    throw std::runtime_error(dir.string() + " is not a folder (a link or a file is there): shared-memory ports are off");
  if (st.st_uid != ::geteuid())
    throw std::runtime_error(dir.string() + " belongs to uid " + std::to_string(st.st_uid) +
                             ", not to this user: shared-memory ports are off");
  if ((st.st_mode & 077) != 0) {
    std::ostringstream mode;
    mode << std::oct << (st.st_mode & 0777);
    throw std::runtime_error(dir.string() + " is open to other users (mode " + mode.str() +
                             "): shared-memory ports are off");
  }
}

// "label.pid.start.counter.shm" -> pid and start time; false for another kind of name.
bool parse_name(std::string_view name, long& pid, unsigned long long& start) {
  if (name.size() <= kSuffix.size() || !name.ends_with(kSuffix)) return false;
  name.remove_suffix(kSuffix.size());
  std::vector<std::string_view> parts;
  for (int i = 0; i < 3; ++i) {
    const auto dot = name.rfind('.');
    if (dot == std::string_view::npos) return false;
    parts.push_back(name.substr(dot + 1));
    name = name.substr(0, dot);
  }
  // parts: counter, start, pid
  const std::string pid_text(parts[2]), start_text(parts[1]);
  if (pid_text.empty() || start_text.empty() || pid_text.find_first_not_of("0123456789") != std::string::npos ||
      start_text.find_first_not_of("0123456789") != std::string::npos)
    return false;
  pid = std::strtol(pid_text.c_str(), nullptr, 10);
  start = std::strtoull(start_text.c_str(), nullptr, 10);
  return pid > 0;
}

bool valid_name(std::string_view name) {
  if (name.empty() || name.size() > 200 || name.front() == '.' || !name.ends_with(kSuffix)) return false;
  for (const char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
  return true;
}

void* map(int fd, std::size_t bytes, const std::string& what) {
  void* data = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_SHARED | MAP_POPULATE, fd, 0);
  if (data == MAP_FAILED) throw std::runtime_error("cannot map " + what + ": " + errno_text());
  return data;
}

}  // namespace

unsigned long long process_start_ticks(long pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text;
  if (!in || !std::getline(in, text)) return 0;
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  for (int i = 3; i <= 22 && fields >> field; ++i)
    if (i == 22) return std::strtoull(field.c_str(), nullptr, 10);
  return 0;
}

std::string shm_host_identity() {
  std::ifstream boot("/proc/sys/kernel/random/boot_id");
  std::string id;
  std::getline(boot, id);
  struct stat net {};
  const std::string ns = ::stat("/proc/self/ns/net", &net) == 0 ? std::to_string(net.st_ino) : "?";
  return (id.empty() ? "?" : id) + "/net:" + ns;
}

fs::path ShmSegment::folder() {
  const char* runtime = std::getenv("XDG_RUNTIME_DIR");
  if (runtime && runtime[0] == '/' && on_tmpfs(runtime)) {
    struct stat st {};
    if (::stat(runtime, &st) == 0 && S_ISDIR(st.st_mode) && st.st_uid == ::geteuid()) {
      const fs::path dir = fs::path(runtime) / "rtm-shm";
      ensure_private_folder(dir);
      return dir;
    }
  }
  if (!on_tmpfs("/dev/shm"))
    throw std::runtime_error("/dev/shm is not a tmpfs and XDG_RUNTIME_DIR names none: shared-memory ports are off");
  const fs::path dir = "/dev/shm/rtm-" + std::to_string(::geteuid());
  ensure_private_folder(dir);
  return dir;
}

int ShmSegment::remove_stale() {
  const fs::path dir = folder();
  DIR* listing = ::opendir(dir.c_str());
  if (!listing) return 0;
  int removed = 0;
  while (const dirent* entry = ::readdir(listing)) {
    long pid = 0;
    unsigned long long start = 0;
    if (!parse_name(entry->d_name, pid, start)) continue;
    if (process_start_ticks(pid) == start) continue;  // its maker still runs
    struct stat st {};
    if (::fstatat(::dirfd(listing), entry->d_name, &st, AT_SYMLINK_NOFOLLOW) != 0 || !S_ISREG(st.st_mode) ||
        st.st_uid != ::geteuid())
      continue;
    if (::unlinkat(::dirfd(listing), entry->d_name, 0) == 0) ++removed;
  }
  ::closedir(listing);
  return removed;
}

ShmSegment ShmSegment::create(std::size_t bytes, std::string_view label) {
  if (bytes == 0 || bytes > kMaxSegmentBytes)
    throw std::runtime_error("a shared-memory segment of " + std::to_string(bytes) + " bytes (1 byte to 256 MiB)");
  remove_stale();
  static std::atomic<std::uint64_t> counter{0};
  // A name never starts with a dot: "s" before every label.
  std::ostringstream text;
  text << 's';
  for (const char c : label.substr(0, 120))
    text << (std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '-' ? c : '_');
  const long pid = ::getpid();
  text << '.' << pid << '.' << process_start_ticks(pid) << '.' << counter.fetch_add(1) << kSuffix;
  const std::string name = text.str();
  const fs::path path = folder() / name;
  const Fd fd(::open(path.c_str(), O_RDWR | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0600));
  if (fd.fd < 0) throw std::runtime_error("cannot create " + path.string() + ": " + errno_text());
  // Pages reserved now: a full tmpfs fails here with a message, not later with SIGBUS.
  if (::fchmod(fd.fd, 0600) != 0 || ::posix_fallocate(fd.fd, 0, static_cast<off_t>(bytes)) != 0) {
    const std::string why = errno_text();
    ::unlink(path.c_str());
    throw std::runtime_error("cannot size " + path.string() + " to " + std::to_string(bytes) + " bytes: " + why);
  }
  try {
    return ShmSegment(map(fd.fd, bytes, path.string()), bytes, name, true);
  } catch (...) {
    ::unlink(path.c_str());
    throw;
  }
}

ShmSegment ShmSegment::open(std::string_view name) {
  if (!valid_name(name))
    throw std::runtime_error("'" + std::string(name.substr(0, 64)) + "' is not a shared-memory segment's name");
  const fs::path path = folder() / std::string(name);
  const Fd fd(::open(path.c_str(), O_RDWR | O_NOFOLLOW | O_NONBLOCK | O_CLOEXEC));
  if (fd.fd < 0) throw std::runtime_error("cannot open " + path.string() + ": " + errno_text());
  struct stat st {};
  if (::fstat(fd.fd, &st) != 0) throw std::runtime_error("cannot look at " + path.string() + ": " + errno_text());
  if (!S_ISREG(st.st_mode) || st.st_uid != ::geteuid() || (st.st_mode & 077) != 0)
    throw std::runtime_error(path.string() + " is not a 0600 file of this user: not mapped");
  if (st.st_size <= 0 || static_cast<std::size_t>(st.st_size) > kMaxSegmentBytes)
    throw std::runtime_error(path.string() + " has " + std::to_string(st.st_size) + " bytes (1 byte to 256 MiB)");
  const auto bytes = static_cast<std::size_t>(st.st_size);
  return ShmSegment(map(fd.fd, bytes, path.string()), bytes, std::string(name), false);
}

ShmSegment::ShmSegment(ShmSegment&& other) noexcept
    : data_(std::exchange(other.data_, nullptr)),
      size_(std::exchange(other.size_, 0)),
      name_(std::move(other.name_)),
      owner_(std::exchange(other.owner_, false)) {}

ShmSegment& ShmSegment::operator=(ShmSegment&& other) noexcept {
  if (this != &other) {
    release();
    data_ = std::exchange(other.data_, nullptr);
    size_ = std::exchange(other.size_, 0);
    name_ = std::move(other.name_);
    owner_ = std::exchange(other.owner_, false);
  }
  return *this;
}

ShmSegment::~ShmSegment() { release(); }

void ShmSegment::release() {
  if (data_) ::munmap(data_, size_);
  if (owner_) {
    try {
      ::unlink((folder() / name_).c_str());
    } catch (const std::exception&) {
      // The folder became unusable meanwhile: the next create() removes the file.
    }
  }
  data_ = nullptr;
  owner_ = false;
}

}  // namespace rtm
