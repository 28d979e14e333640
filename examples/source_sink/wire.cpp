// SPDX-License-Identifier: Apache-2.0
// rtm-example-wire: connects one component's OutPort to another's InPort (subscribe, as the
// paper's component editor did) and turns both components on.
//
//   rtm-example-wire --naming 127.0.0.1:2809 source0.out0 sink0.in0
//
// Components are found by name in the naming service (any host, or host/name).
#include "rtm/naming.h"
#include "rtm/orb.h"

#include <RTMExt.hh>

#include <CLI/CLI.hpp>

#include <cstdio>
#include <stdexcept>
#include <string>

namespace {

struct PortName {
  std::string component;
  std::string port;
};

PortName split_port(const std::string& text) {
  const auto dot = text.rfind('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == text.size()) {
    throw std::invalid_argument("'" + text + "': expected <component>.<port>");
  }
  return {text.substr(0, dot), text.substr(dot + 1)};
}

template <class List>
auto find_port(const List& ports, const PortName& wanted) {
  for (CORBA::ULong i = 0; i < ports.length(); ++i) {
    CORBA::String_var name = ports[i]->name();
    if (wanted.port == name.in()) return ports[i].in();
  }
  throw std::invalid_argument(wanted.component + " has no port '" + wanted.port + "'");
}

}  // namespace

int main(int argc, char** argv) {
  std::string naming_text = rtm::NamingAddress::from_environment().to_string();
  std::string from_text;
  std::string to_text;
  CLI::App app("rtm-example-wire: subscribe <component>.<outport> to <component>.<inport>, turn both on");
  app.add_option("--naming", naming_text, "naming service host:port")->capture_default_str();
  app.add_option("from", from_text, "<component>.<outport>")->required();
  app.add_option("to", to_text, "<component>.<inport>")->required();
  CLI11_PARSE(app, argc, argv);

  try {
    const auto from = split_port(from_text);
    const auto to = split_port(to_text);
    rtm::Orb orb({"-ORBendPoint", "giop:tcp:127.0.0.1:"});
    rtm::NamingClient naming(orb.orb(), rtm::NamingAddress::parse(naming_text));
    auto source = naming.resolve_component(from.component);
    auto sink = naming.resolve_component(to.component);
    RTM::OutPortList_var outs = source->out_ports();
    RTM::InPortList_var ins = sink->in_ports();
    RTM::OutPort_ptr out = find_port(outs.in(), from);
    RTM::InPort_ptr in = find_port(ins.in(), to);
    if (!out->subscribe(RTM::repeated, in)) {
      RTM::OutPortEx_var out_ex = RTM::OutPortEx::_narrow(out);
      CORBA::String_var why = CORBA::is_nil(out_ex) ? CORBA::string_dup("") : out_ex->last_error();
      std::fprintf(stderr, "rtm-example-wire: %s refused %s: %s\n", from_text.c_str(), to_text.c_str(), why.in());
      return 1;
    }
    sink->on();
    source->on();
    std::printf("connected %s -> %s, both on\n", from_text.c_str(), to_text.c_str());
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "rtm-example-wire: %s\n", e.what());
  } catch (const CORBA::Exception& e) {
    std::fprintf(stderr, "rtm-example-wire: CORBA %s\n", e._name());
  }
  return 1;
}
