// SPDX-License-Identifier: Apache-2.0
#include "new_command.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

namespace rtm::cli {

void NewCommand::add_to(CLI::App& app) {
  CLI::App* made = app.add_subcommand("new", "start a project of your own on RTM");
  made->require_subcommand(1);
  component = made->add_subcommand("component", "a component project: logic, test, executable, system file");
  component->add_option("name", name, "lower-case words joined by '_', e.g. gripper_ctl")->required();
  std::string types;
  for (const auto& t : known_port_types()) types += (types.empty() ? "" : ", ") + t.substr(5);
  component->add_option("--in", in,
                         "an InPort, name:Type (repeatable); types: " + types +
                             ", or Module::Type of your own IDL (with --idl or --types)");
  component->add_option("--out", out, "an OutPort, name:Type (repeatable)");
  component->add_option("--period", period, "the cycle period its system file starts it with")
      ->capture_default_str();
  component->add_option("--description", description, "what it does, in one line: its --help says it");
  component->add_option("--param", params,
                        "a parameter its cycle reads and `rtm set` changes, name:unit:default[:description] "
                        "(repeatable), e.g. cutoff_hz:Hz:10");
  component->add_option("--idl", idl, "an IDL file declaring port types of your own: copied into the project, "
                                      "compiled there (repeatable)");
  component->add_option("--types", type_packages,
                        "a package of port types installed by rtm_add_idl(<package> ... TYPES ... EXPORT) "
                        "(repeatable)");
  component->add_option("--dir", parent, "the folder to make the project in")->capture_default_str();
  component->add_flag("--python", python,
                      "a component in Python (import rtm, docs/python.md): its class, a test of its logic, a "
                      "system file; built-in port types only");
}

bool NewCommand::parsed() const { return component->parsed(); }

void NewCommand::run(bool json) const {
  ScaffoldOptions options;
  options.name = name;
  for (const auto& spec : in) options.in.push_back(parse_port_spec(spec));
  for (const auto& spec : out) options.out.push_back(parse_port_spec(spec));
  options.period = period;
  options.parent = parent;
  options.description = description;
  for (const auto& spec : params) options.params.push_back(parse_param_spec(spec));
  options.idl.assign(idl.begin(), idl.end());
  options.type_packages = type_packages;
  options.python = python;
  const auto files = scaffold_component(options);
  const std::filesystem::path project = options.parent / options.name;
  if (json) {
    nlohmann::json list = nlohmann::json::array();
    for (const auto& f : files) list.push_back(f.string());
    fmt::print("{}\n", nlohmann::json{{"project", project.string()}, {"files", list}}.dump());
    return;
  }
  for (const auto& f : files) fmt::print("made {}\n", f.string());
  if (python) {
    fmt::print("next: cd {} && python3 -m pytest   (with PYTHONPATH=<RTM's prefix>/lib/python3/dist-packages unless "
               "RTM came from its .deb), then rtm up {}.yaml\n",
               project.string(), options.name);
    return;
  }
  fmt::print("next: cd {} && cmake -B build -DCMAKE_PREFIX_PATH=<RTM's prefix> && cmake --build build -j && "
             "ctest --test-dir build\n",
             project.string());
}

}  // namespace rtm::cli
