// SPDX-License-Identifier: Apache-2.0
// rtm-test-impostor: what an attacker would bind under a name `rtm up` waits for. An RTM
// component (rtm::Component, served in this process, bound with rtm::NamingClient) whose "pid"
// statistic says whatever --claim-pid says, so that a check trusting what an object says of
// itself is fooled. It ends by itself when its parent process ends.
//   rtm-test-impostor --claim-pid PID --name NAME --naming HOST:PORT
#include "rtm/component.h"
#include "rtm/naming.h"
#include "rtm/orb.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

namespace {

class Impostor final : public rtm::Component {
 public:
  Impostor(const std::string& name, double claimed_pid) : Component(name, "talker") {
    add_statistic("pid", "", "the process the component runs in", [claimed_pid] { return claimed_pid; });
  }
  void on_cycle(const rtm::CycleContext&) override {}

 private:
  rtm::OutPort<RTM::TimedFloat6>& force_ = add_out_port<RTM::TimedFloat6>("force");
};

}  // namespace

int main(int argc, char** argv) {
  std::string name, naming;
  double claimed = 0;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string option = argv[i];
    if (option == "--claim-pid") claimed = std::atof(argv[i + 1]);
    if (option == "--name") name = argv[i + 1];
    if (option == "--naming") naming = argv[i + 1];
  }
  if (name.empty() || naming.empty()) {
    std::fprintf(stderr, "usage: rtm-test-impostor --claim-pid PID --name NAME --naming HOST:PORT\n");
    return 2;
  }
  const pid_t parent = ::getppid();
  rtm::Orb orb;
  PortableServer::Servant_var<rtm::ComponentServant> servant(
      new rtm::ComponentServant(std::make_unique<Impostor>(name, claimed), rtm::ExternalTick{}));
  RTM::RtComponentEx_var reference = servant->activate(orb);
  rtm::NamingClient(orb.orb(), rtm::NamingAddress::parse(naming)).bind(rtm::ComponentPath::on_this_host(name),
                                                                       reference.in());
  std::printf("bound %s claiming pid %.0f\n", name.c_str(), claimed);
  std::fflush(stdout);
  while (::getppid() == parent) std::this_thread::sleep_for(std::chrono::milliseconds(100));
  servant->deactivate();
  return 0;
}
