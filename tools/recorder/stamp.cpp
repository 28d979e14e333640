// SPDX-License-Identifier: Apache-2.0
#include "stamp.h"

#include <cstring>

namespace rtm::cli {

namespace {
constexpr std::size_t kStampAt = 4;  // after the encapsulation header
}  // namespace

std::uint64_t stamp_of(const std::vector<std::uint8_t>& cdr) {
  std::uint32_t sec = 0;
  std::uint32_t nsec = 0;
  if (cdr.size() < kStampAt + 8) return 0;
  std::memcpy(&sec, cdr.data() + kStampAt, sizeof sec);
  std::memcpy(&nsec, cdr.data() + kStampAt + 4, sizeof nsec);
  return std::uint64_t{sec} * 1'000'000'000ULL + nsec;
}

void restamp(std::vector<std::uint8_t>& cdr, std::uint64_t ns) {
  if (cdr.size() < kStampAt + 8) return;
  const auto sec = static_cast<std::uint32_t>(ns / 1'000'000'000ULL);
  const auto nsec = static_cast<std::uint32_t>(ns % 1'000'000'000ULL);
  std::memcpy(cdr.data() + kStampAt, &sec, sizeof sec);
  std::memcpy(cdr.data() + kStampAt + 4, &nsec, sizeof nsec);
}

}  // namespace rtm::cli
