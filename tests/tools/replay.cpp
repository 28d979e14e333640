// SPDX-License-Identifier: Apache-2.0
// rtm-test-replay: one GIOP request as an attacker sends it, byte by byte (rtm_test/raw_giop.h):
//   rtm-test-replay IOR OPERATION [ID:HEXDATA ...]
// sends OPERATION with no arguments and the given service contexts to the object's IIOP
// address, and prints the reply: "reply <status> <exception repository id> <minor>", or
// "no reply". Run as another user (setpriv) or from another network namespace by the tests.
#include "rtm_test/raw_giop.h"

#include <cstdio>
#include <string>
#include <vector>

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: rtm-test-replay IOR OPERATION [ID:HEXDATA ...]\n");
    return 2;
  }
  std::vector<rtm_test::ServiceContext> contexts;
  for (int i = 3; i < argc; ++i) {
    const std::string text = argv[i];
    const auto colon = text.find(':');
    rtm_test::ServiceContext context;
    context.id = static_cast<std::uint32_t>(std::stoul(text.substr(0, colon), nullptr, 0));
    for (std::size_t k = colon + 1; k + 1 < text.size(); k += 2)
      context.data.push_back(static_cast<std::uint8_t>(std::stoul(text.substr(k, 2), nullptr, 16)));
    contexts.push_back(std::move(context));
  }
  const auto reply = rtm_test::giop_request(rtm_test::iiop_profile(argv[1]), argv[2], {}, 5000, contexts);
  if (!reply) {
    std::printf("no reply\n");
    return 1;
  }
  std::printf("reply %u %s %u\n", reply->status, reply->exception.empty() ? "-" : reply->exception.c_str(),
              reply->minor);
  return 0;
}
