// SPDX-License-Identifier: Apache-2.0
#include "integration_fixture.h"

#include <stdexcept>

namespace rtm_it {

namespace {

class OrbEnvironment : public ::testing::Environment {
 public:
  void TearDown() override { orb_.reset(); }
  rtm::Orb& get() {
    // rtm::Orb's own endpoints: TCP on loopback and giop:unix:, over which components' puts
    // into the tests' InPorts are let through (host/access.h).
    if (!orb_) orb_ = std::make_unique<rtm::Orb>();
    return *orb_;
  }

 private:
  std::unique_ptr<rtm::Orb> orb_;
};

OrbEnvironment* const environment =
    static_cast<OrbEnvironment*>(::testing::AddGlobalTestEnvironment(new OrbEnvironment));

}  // namespace

rtm::Orb& test_orb() { return environment->get(); }

rtm_test::ChildProcess& IntegrationTest::start_component(const std::string& name, std::vector<std::string> extra_args) {
  std::vector<std::string> argv{RTM_TEST_COMPONENT, "--name", name, "--naming", names_.address(), "--period", "2ms"};
  argv.insert(argv.end(), extra_args.begin(), extra_args.end());
  auto process = std::make_unique<rtm_test::ChildProcess>(std::move(argv));
  process->wait_until_bound();
  components_.push_back(std::move(process));
  return *components_.back();
}

void IntegrationTest::TearDown() {
  for (auto& process : components_) {
    if (!process->running()) continue;  // ended by the test itself
    const auto status = process->stop();
    EXPECT_TRUE(status.clean()) << process->program() << " ended with " << status.to_string() << ":\n"
                                << process->output();
  }
  components_.clear();
}

RTM::RtComponentEx_var IntegrationTest::component(const std::string& name) {
  RTM::RtComponent_var base = naming().resolve_component(name);
  RTM::RtComponentEx_var ex = RTM::RtComponentEx::_narrow(base);
  if (CORBA::is_nil(ex)) throw std::runtime_error(name + " is not an RtComponentEx");
  return ex;
}

RTM::OutPortEx_var IntegrationTest::out_port(const std::string& component_name, const std::string& port_name) {
  RTM::OutPortList_var ports = component(component_name)->out_ports();
  for (CORBA::ULong i = 0; i < ports->length(); ++i) {
    CORBA::String_var name = ports[i]->name();
    if (port_name == name.in()) return RTM::OutPortEx::_narrow(ports[i]);
  }
  throw std::runtime_error(component_name + " has no OutPort " + port_name);
}

RTM::InPortEx_var IntegrationTest::in_port(const std::string& component_name, const std::string& port_name) {
  RTM::InPortList_var ports = component(component_name)->in_ports();
  for (CORBA::ULong i = 0; i < ports->length(); ++i) {
    CORBA::String_var name = ports[i]->name();
    if (port_name == name.in()) return RTM::InPortEx::_narrow(ports[i]);
  }
  throw std::runtime_error(component_name + " has no InPort " + port_name);
}

}  // namespace rtm_it
