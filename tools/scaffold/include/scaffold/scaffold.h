// SPDX-License-Identifier: Apache-2.0
// `rtm new component`: writes the skeleton of a component project that lives outside this tree
// and builds against an installed RTM (find_package(RTM), target RTM::core).
//
//   rtm new component gripper_ctl --in wrench:TimedFloat6 --out grip:TimedFloat --period 1ms
//
// makes ./gripper_ctl/ holding
//   CMakeLists.txt                    library gripper_ctl_logic, executable rtm-gripper_ctl,
//                                     test gripper_ctl_test (GoogleTest, add_test)
//   include/gripper_ctl/gripper_ctl.h class GripperCtl: its ports, and its logic as a static
//   src/gripper_ctl.cpp               function GripperCtl::step(Inputs, [Params,] State&, now)
//                                     -> Outputs, its memory in State (a filter's last output)
//   src/main.cpp                      rtm::run_component (kind "gripper_ctl")
//   test/gripper_ctl_test.cpp         tests of step(), no ORB needed
//   gripper_ctl.yaml                  system file: `rtm up gripper_ctl.yaml` starts gripper_ctl0
//                                     (build/bin/rtm-gripper_ctl --period 1ms) and turns it on
//   idl/<file>.idl                    copies of the --idl files, compiled by rtm_add_idl
//   README.md, .gitignore
//
// With --python (ScaffoldOptions::python), a component in Python (docs/python.md) instead:
//   gripper_ctl.py                    its logic, compute(inputs, params) -> outputs, and class
//                                     GripperCtl(rtm.Component): its ports and parameters; run by
//                                     RTM's runner (rtm.run), executable
//   test_gripper_ctl.py               tests of compute() (pytest), no running system needed
//   gripper_ctl.yaml                  system file: `rtm up gripper_ctl.yaml` runs ./gripper_ctl.py
//   README.md, .gitignore
// Its ports take the built-in types only.
//
// Names: the component name is lower-case words of a-z 0-9 joined by single '_', 1 to 32
// characters, starting with a letter ("gripper_ctl"). The class is the words capitalised
// ("GripperCtl", at global scope: no namespace named after the component, which could clash
// with a C function such as log or time), the executable "rtm-" + name (as the framework's own
// rtm-controller, rtm-sensor, ...), the kind the name, the instance in the system file name +
// "0". The system file names the executable by its path in the project's build folder, so an
// installed program of the same name on $PATH is never picked instead.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

namespace rtm::cli {

// One port of the new component.
struct PortSpec {
  std::string name;  // a C identifier starting with a lower-case letter: "wrench"
  // A built-in timed type, "RTM::TimedFloat6" (the "RTM::" may be left out), or a timed struct
  // of the project's own IDL, "My::TimedPose" (declared in an --idl file or a --types package).
  std::string type;
};

// One parameter of the new component: a number its cycle reads and `rtm set` changes while it
// runs (rtm/parameters.h).
struct ParamSpec {
  std::string name;         // a C identifier starting with a lower-case letter: "cutoff_hz"
  std::string unit;         // "Hz"; may be empty
  double default_value = 0;  // finite
  std::string description;  // one line; "" gives the name in words
};

struct ScaffoldOptions {
  std::string name;  // "gripper_ctl"
  // Both empty: one InPort "in0" and one OutPort "out0", both RTM::TimedFloat6. One empty,
  // the other not: a component with no port of that direction (a source, a sink).
  std::vector<PortSpec> in;
  std::vector<PortSpec> out;
  std::string period = "2ms";  // as the runner's --period takes it; written into the system file
  // What it does, in one line, for its --help (before the list of its ports); "" for the list alone.
  std::string description;
  std::vector<ParamSpec> params;  // at most 8, names unique
  // Where the ports' own types are declared. IDL files are copied into the project's idl/ and
  // compiled there (rtm_add_idl ... TYPES); a package is one a types project installed with
  // rtm_add_idl(<package> ... TYPES ... EXPORT), found by find_package(<package>).
  std::vector<std::filesystem::path> idl;
  std::vector<std::string> type_packages;
  std::filesystem::path parent = ".";  // the project is written to parent / name
  bool python = false;  // a component in Python (built-in port types only), not in C++
};

// The types a port may carry, as "RTM::<type>": the timed types of idl/RTM.idl and
// idl/RTMData.idl that rtm/data.h gives DataTraits to.
const std::vector<std::string>& known_port_types();

// "wrench:TimedFloat6" or "wrench:RTM::TimedFloat6" -> {"wrench", "RTM::TimedFloat6"};
// "pose:My::TimedPose" -> {"pose", "My::TimedPose"}. Throws std::invalid_argument naming the
// text when the name is not a usable port name, or the type is no built-in type (then the
// message lists them) and no Module::Type either.
PortSpec parse_port_spec(std::string_view text);

// "cutoff_hz:Hz:10" or "cutoff_hz:Hz:10:the filter's cut-off" -> a ParamSpec. Throws
// std::invalid_argument naming the text when a part is missing, the name unusable, the unit or
// description holds a quote, a backslash or a control character, or the default is no finite number.
ParamSpec parse_param_spec(std::string_view text);

// The class a component name makes: "gripper_ctl" -> "GripperCtl". Throws
// std::invalid_argument naming the name when it is not a usable component name.
std::string class_name_of(std::string_view component_name);

// Writes the project into options.parent / options.name (made, with parent, when missing) and
// returns the files written, in that folder, in the order listed above.
//
// Everything is checked before anything is written: std::invalid_argument naming the offending
// input for a bad component name, port name, port type, period, or a port name used twice, a
// type of the project's own that no --idl file declares as a timed struct (or with neither
// --idl nor --types given), an IDL file that cannot be read, or a bad package name;
// std::runtime_error naming the folder when it exists and is not empty (nothing in it is ever
// overwritten), or when a file cannot be written (what was written by this call is removed
// again).
std::vector<std::filesystem::path> scaffold_component(const ScaffoldOptions& options);

}  // namespace rtm::cli
