// SPDX-License-Identifier: Apache-2.0
// The text helpers the demo's report files share (demo_report.cpp, script_report.cpp): not part
// of the report's interface.
#pragma once

#include <charconv>
#include <filesystem>
#include <string>
#include <string_view>
#include <system_error>

namespace rtm::demo::text {

// A number alone in `text` (spaces around it allowed); false for anything else.
// from_chars: locale-independent, unlike strtod.
template <typename T>
bool parse_number(std::string_view text, T& value) {
  while (!text.empty() && text.front() == ' ') text.remove_prefix(1);
  while (!text.empty() && (text.back() == ' ' || text.back() == '\r')) text.remove_suffix(1);
  if (text.empty()) return false;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  return ec == std::errc() && end == text.data() + text.size();
}

// The whole file; ReportError "<path>: cannot read" when it cannot be opened.
std::string read_file(const std::filesystem::path& path);

}  // namespace rtm::demo::text
