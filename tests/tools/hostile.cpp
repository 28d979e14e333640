// SPDX-License-Identifier: Apache-2.0
// rtm-test-hostile: what another local user could put in front of `rtm serve`'s page. Every
// string it reports is a cross-site scripting payload whose script, if a page ever ran it,
// would ask the test's listener (--beacon URL) for <URL>/<where> and then go there: its kind,
// its description, its statistics' names, units and descriptions, its parameters' names,
// values, units and descriptions, its ports' names, descriptions and elements, and its last
// error (its first cycle throws it: started with --on it is in error at once). It also binds
// its own reference in the naming service under names that break the naming rule, each a
// payload too (what rtm::NamingClient::bind lets anyone do): the names `rtm serve` must show
// as text, marked, with nothing to click.
//   --beacon URL     the listener (default http://127.0.0.1:9)
//   --bind-names     bind it under the hostile names too
//   --plain          report plain strings (a component to reach under the hostile names)
#include "rtm/data.h"
#include "rtm/naming.h"
#include "rtm/orb.h"
#include "host/runner.h"

#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

// The payloads, each of whose scripts would report `where` (plus the payload's number).
std::vector<std::string> payloads(const std::string& beacon, const std::string& where) {
  std::vector<std::string> out;
  const auto go = [&](int i) {
    const std::string url = beacon + "/" + where + std::to_string(i);
    return "fetch('" + url + "');location='" + url + "-went'";
  };
  out.push_back("<img src=x onerror=\"" + go(0) + "\">");
  out.push_back("<svg onload=\"" + go(1) + "\">");
  out.push_back("\"><script>" + go(2) + "</script>");
  out.push_back("javascript:" + go(3));
  out.push_back("'><iframe srcdoc=\"<script>parent." + go(4) + "</script>\"></iframe>");
  out.push_back("</text><foreignObject><img src=x onerror=\"" + go(5) + "\"></foreignObject>");
  out.push_back("${" + go(6) + "}<a href=\"javascript:" + go(7) + "\">x</a>");
  return out;
}

class Hostile final : public rtm::Component {
 public:
  Hostile(const std::string& name, const std::string& beacon)
      : Component(name, payloads(beacon, "kind")[0]) {
    set_description(payloads(beacon, "description")[1]);
    const auto names = payloads(beacon, "statistic"), units = payloads(beacon, "unit"),
               texts = payloads(beacon, "statistic-description");
    for (std::size_t i = 0; i < names.size(); ++i)
      add_statistic(names[i], units[i], texts[i], [i] { return static_cast<double>(i); });
    const auto parameters = payloads(beacon, "parameter"), values = payloads(beacon, "value"),
               descriptions = payloads(beacon, "parameter-description");
    values_ = values;
    for (std::size_t i = 0; i < parameters.size(); ++i)
      add_parameter({.name = parameters[i],
                     .unit = units[i],
                     .description = descriptions[i],
                     .access = i % 2 == 0 ? rtm::ParameterAccess::live : rtm::ParameterAccess::fixed,
                     .get = [this, i] {
                       std::lock_guard lock(mu_);
                       return values_[i];
                     },
                     .set = [this, i](std::string_view text) {
                       std::lock_guard lock(mu_);
                       values_[i] = std::string(text);
                     }});
    error_ = payloads(beacon, "error")[2];
    const auto ports = payloads(beacon, "port"), port_texts = payloads(beacon, "port-description"),
               elements = payloads(beacon, "element");
    const std::vector<rtm::Element> three{{elements[0], elements[1]}, {elements[2], elements[3]}, {elements[4], elements[5]}};
    for (std::size_t i = 0; i < 3; ++i) {
      add_in_port<RTM::TimedFloat3>(ports[i], rtm::PortInfo{port_texts[i], three});
      add_out_port<RTM::TimedFloat3>(ports[i + 3], rtm::PortInfo{port_texts[i + 3], three});
    }
  }

  void on_cycle(const rtm::CycleContext&) override { throw std::runtime_error(error_); }

 private:
  std::mutex mu_;
  std::vector<std::string> values_;
  std::string error_;
};

// Names no RTM component may have: the payloads, a backslash (which a browser turns into a
// '/' in a path), a '/', and one that is too long.
std::vector<std::string> hostile_names(const std::string& beacon) {
  std::vector<std::string> names = payloads(beacon, "name");
  names.push_back("back\\slash");
  names.push_back("slash/ed");
  names.push_back(std::string(65, 'n'));
  return names;
}

// A component with plain strings (--plain), to be reached under the hostile names.
class Plain final : public rtm::Component {
 public:
  explicit Plain(const std::string& name) : Component(name, "plain") {}
  void on_cycle(const rtm::CycleContext&) override {}
};

}  // namespace

int main(int argc, char** argv) {
  std::string beacon = "http://127.0.0.1:9";
  bool plain = false, bind_names = false;
  return rtm::run_component(argc, argv, {
      .kind = "hostile",
      .description = "test component whose every string is a cross-site scripting payload",
      .add_options = [&](CLI::App& app) {
        app.add_option("--beacon", beacon, "URL a payload's script would report to");
        app.add_flag("--plain", plain, "report plain strings, not payloads");
        app.add_flag("--bind-names", bind_names, "bind this component under names that break the naming rule too");
      },
      .create = [&](const rtm::RunSettings& s) -> std::unique_ptr<rtm::Component> {
        if (plain) return std::make_unique<Plain>(s.name);
        return std::make_unique<Hostile>(s.name, beacon);
      },
      .activity = {},
      .on_activated = [&](rtm::ComponentServant& servant, const rtm::RunContext& context) {
        if (bind_names) {
          const rtm::NamingClient naming(context.orb.orb(), context.settings.naming);
          CORBA::Object_var reference = servant.reference();
          for (const auto& name : hostile_names(beacon))
            naming.bind(rtm::ComponentPath::on_this_host(name), reference.in());
        }
        return std::vector<rtm::ExtraName>{};
      },
  });
}
