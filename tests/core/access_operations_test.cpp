// SPDX-License-Identifier: Apache-2.0
// The access screen (host/access.h) must know every operation of our IDL: one it does not list
// as a change is served to anyone, so an operation added without its line is a hole. Reads
// are listed here by hand; every other operation the IDL files declare must be a change.
#include "host/access.h"

#include <gtest/gtest.h>

#include <fstream>
#include <cctype>
#include <set>
#include <sstream>
#include <string>

namespace {

// The name before the first '(' of each declaration line ("<type> <name>(" ...), comments cut
// off first. (No std::regex: GCC 12's <regex> does not build warning-free under ASan.)
std::set<std::string> operations_in(const std::string& file) {
  std::ifstream in(file);
  EXPECT_TRUE(in) << "cannot read " << file;
  std::set<std::string> ops;
  const auto word_char = [](char c) { return std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '_'; };
  for (std::string line; std::getline(in, line);) {
    line = line.substr(0, line.find("//"));
    const std::size_t open = line.find('(');
    if (open == std::string::npos) continue;
    std::size_t end = open;
    while (end > 0 && line[end - 1] == ' ') --end;
    std::size_t begin = end;
    while (begin > 0 && word_char(line[begin - 1])) --begin;
    // A declaration has its type before the name on the same line.
    if (begin == end || line.find_first_not_of(" \t") >= begin) continue;
    ops.insert(line.substr(begin, end - begin));
  }
  return ops;
}

TEST(AccessOperations, EveryOperationOfTheIdlIsAReadListedHereOrAChangeTheScreenKnows) {
  const std::set<std::string> reads = {"get",   "in_ports", "out_ports",  "counters",   "describe",
                                       "state", "timing",   "statistics", "parameters", "subscriptions",
                                       "last_error", "members", "contract"};
  std::set<std::string> ops = operations_in(std::string(RTM_IDL_DIR) + "/RTM.idl");
  const std::set<std::string> ext = operations_in(std::string(RTM_IDL_DIR) + "/RTMExt.idl");
  ops.insert(ext.begin(), ext.end());
  ASSERT_GE(ops.size(), 25u) << "the IDL parse found too little to prove anything";
  EXPECT_TRUE(ops.count("connect")) << "the parse misses an operation it must see";
  for (const std::string& op : ops) {
    if (reads.count(op)) {
      EXPECT_FALSE(rtm::is_change_operation(op)) << op << " is a read";
    } else {
      EXPECT_TRUE(rtm::is_change_operation(op)) << op << ": an operation the access screen does not know as a change";
    }
  }
  for (const std::string& read : reads) EXPECT_TRUE(ops.count(read)) << read << " is listed but not in the IDL";
}

}  // namespace
