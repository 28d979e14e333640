// SPDX-License-Identifier: Apache-2.0
// A second process for the rtm_core tests: serves one InPort<TimedFloat6> ("peer0.in0") and
// prints its IOR on stdout; exits when its stdin closes. Its POA and object id look like the
// test's own, so only a correct locality check tells them apart.
#include "rtm/inport.h"
#include "rtm/orb.h"

#include <iostream>
#include <string>
#include <thread>

int main() {
  rtm::Orb orb;
  PortableServer::Servant_var<rtm::InPort<RTM::TimedFloat6>> port = new rtm::InPort<RTM::TimedFloat6>("in0", "peer0");
  RTM::InPortEx_var ref = port->activate(orb);
  std::cout << orb.to_string(ref.in()) << std::endl;
  std::thread stdin_watch([&orb] {
    std::string line;
    while (std::getline(std::cin, line)) {
    }
    orb.shutdown();
  });
  orb.run();
  stdin_watch.join();
  port->deactivate();
  return 0;
}
