// SPDX-License-Identifier: Apache-2.0
#include "scaffold/scaffold.h"

#include "scaffold_templates.h"

#include "host/runner.h"  // parse_period_ns: the period as the runner takes it

#include "rtm/data.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cerrno>
#include <cstdio>
#include <map>
#include <set>
#include <stdexcept>
#include <system_error>

namespace rtm::cli {
namespace {

namespace fs = std::filesystem;

bool lower_or_digit(char c) { return (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9'); }
bool letter_or_digit(char c) { return lower_or_digit(c) || (c >= 'A' && c <= 'Z'); }
bool identifier_char(char c) { return letter_or_digit(c) || c == '_'; }

// ============================ port types ==============================

// How a timed type holds its values, which is all the generated step() and test need to know.
using Shape = rtm::DataShape;

struct TypeInfo {
  std::string_view name;     // in module RTM
  Shape shape;
  std::string_view field;    // the member holding the values
  int elements;              // array: its length
  std::string_view element;  // C++ type of one value
};

// The built-in types, from their one list (rtm/data.h).
#define RTM_TYPE_INFO(Type, Shape_, Member, Elements, ElementType) \
  {#Type, Shape::Shape_, #Member, Elements, #ElementType},
constexpr TypeInfo kTypes[] = {RTM_BUILTIN_DATA_TYPES(RTM_TYPE_INFO)};
#undef RTM_TYPE_INFO

std::string full_name(const TypeInfo& t) { return fmt::format("RTM::{}", t.name); }

std::string known_types_text() {
  std::string text;
  for (const auto& t : kTypes) text += fmt::format("{}{}", text.empty() ? "" : ", ", t.name);
  return text;
}

bool same_ignoring_case(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const auto lower = [](char c) { return c >= 'A' && c <= 'Z' ? static_cast<char>(c - 'A' + 'a') : c; };
    if (lower(a[i]) != lower(b[i])) return false;
  }
  return true;
}

// "TimedFloat6" or "RTM::TimedFloat6"; `what` names the port for the error.
const TypeInfo& find_type(std::string_view type, std::string_view what) {
  const std::string_view bare = type.starts_with("RTM::") ? type.substr(5) : type;
  for (const auto& t : kTypes) {
    if (bare == t.name) return t;
  }
  std::string hint;
  for (const auto& t : kTypes) {
    if (same_ignoring_case(bare, t.name)) hint = fmt::format(" (did you mean {}?)", t.name);
  }
  throw std::invalid_argument(fmt::format("{}: '{}' is not a port type{}; known types: {}; a type of your own IDL "
                                          "is written Module::Type (e.g. My::TimedPose), with --idl or --types",
                                          what, type, hint, known_types_text()));
}

bool is_idl_identifier(std::string_view s) {
  return !s.empty() && letter_or_digit(s.front()) && !(s.front() >= '0' && s.front() <= '9') &&
         std::all_of(s.begin(), s.end(), identifier_char);
}

// "My::TimedPose", "Lab::Arm::TimedGrip": a struct in a module of the project's own IDL (not RTM's).
bool is_own_type_name(std::string_view type) {
  std::size_t parts = 0;
  for (std::size_t at = 0;; ++parts) {
    const auto sep = type.find("::", at);
    const auto part = type.substr(at, sep == std::string_view::npos ? std::string_view::npos : sep - at);
    if (!is_idl_identifier(part) || (parts == 0 && part == "RTM")) return false;
    if (sep == std::string_view::npos) break;
    at = sep + 2;
  }
  return parts >= 1;
}

// =============================== own IDL ==============================

// The structs an IDL file declares, by qualified name, split by whether they are timed (their
// first member `RTM::Time tm`, the stamp the generated code and the tools use).
struct IdlStructs {
  std::set<std::string> timed, untimed;
};

// Identifiers, "::" and single characters; comments, preprocessor lines and literals left out.
std::vector<std::string_view> idl_tokens(std::string_view text) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  const auto skip_to = [&](std::string_view end) {
    const auto found = text.find(end, i);
    i = found == std::string_view::npos ? text.size() : found + end.size();
  };
  while (i < text.size()) {
    const char c = text[i];
    if (c == ' ' || c == '\t' || c == '\n' || c == '\r') {
      ++i;
    } else if (text.substr(i, 2) == "//" || c == '#') {
      skip_to("\n");
    } else if (text.substr(i, 2) == "/*") {
      i += 2;
      skip_to("*/");
    } else if (c == '"' || c == '\'') {
      const auto close = text.find(c, i + 1);
      i = close == std::string_view::npos ? text.size() : close + 1;
    } else if (text.substr(i, 2) == "::") {
      tokens.push_back(text.substr(i, 2));
      i += 2;
    } else if (identifier_char(c)) {
      const std::size_t start = i;
      while (i < text.size() && identifier_char(text[i])) ++i;
      tokens.push_back(text.substr(start, i - start));
    } else {
      tokens.push_back(text.substr(i++, 1));
    }
  }
  return tokens;
}

IdlStructs scan_idl(std::string_view text) {
  const auto t = idl_tokens(text);
  IdlStructs found;
  std::vector<std::pair<std::string, int>> modules;  // name, the depth of its '{'
  int depth = 0;
  const auto at = [&](std::size_t i) { return i < t.size() ? t[i] : std::string_view(); };
  for (std::size_t i = 0; i < t.size(); ++i) {
    if ((t[i] == "module" || t[i] == "struct") && is_idl_identifier(at(i + 1)) && at(i + 2) == "{") {
      std::string scope;
      for (const auto& m : modules) scope += m.first + "::";
      if (t[i] == "module") {
        modules.emplace_back(std::string(t[i + 1]), depth++);
      } else {
        const bool in_rtm = scope == "RTM::";
        const bool timed = (at(i + 3) == "RTM" && at(i + 4) == "::" && at(i + 5) == "Time" && at(i + 6) == "tm") ||
                           (in_rtm && at(i + 3) == "Time" && at(i + 4) == "tm");
        (timed ? found.timed : found.untimed).insert(scope + std::string(t[i + 1]));
        ++depth;
      }
      i += 2;
    } else if (t[i] == "{") {
      ++depth;
    } else if (t[i] == "}") {
      --depth;
      if (!modules.empty() && modules.back().second == depth) modules.pop_back();
    }
  }
  return found;
}

// ================================ names ===============================


// Words a port name cannot be: it becomes a struct member in the generated C++.
const std::set<std::string_view>& reserved_port_names() {
  static const std::set<std::string_view> words = {
      "alignas", "alignof", "and", "and_eq", "asm", "auto", "bitand", "bitor", "bool", "break", "case", "catch",
      "char", "char8_t", "char16_t", "char32_t", "class", "compl", "concept", "const", "consteval", "constexpr",
      "constinit", "const_cast", "continue", "co_await", "co_return", "co_yield", "decltype", "default", "delete",
      "do", "double", "dynamic_cast", "else", "enum", "explicit", "export", "extern", "false", "float", "for",
      "friend", "goto", "if", "inline", "int", "long", "mutable", "namespace", "new", "noexcept", "not", "not_eq",
      "nullptr", "operator", "or", "or_eq", "private", "protected", "public", "register", "reinterpret_cast",
      "requires", "return", "short", "signed", "sizeof", "static", "static_assert", "static_cast", "struct",
      "switch", "template", "this", "thread_local", "throw", "true", "try", "typedef", "typeid", "typename",
      "union", "unsigned", "using", "virtual", "void", "volatile", "wchar_t", "while", "xor", "xor_eq",
      // object-like macros of the C library and of GNU mode
      "errno", "linux", "unix"};
  return words;
}

// Lower-case words of a-z 0-9 joined by single '_': it names the folder, the CMake project and
// targets, the executable, the kind and (capitalised) the class.
void check_component_name(std::string_view name) {
  const auto bad = [&](std::string_view why) {
    throw std::invalid_argument(fmt::format(
        "component name '{}' {}: use 1 to 32 of a-z 0-9 '_', starting with a letter, words joined by "
        "single '_' (e.g. gripper_ctl)",
        name, why));
  };
  if (name.empty()) bad("is empty");
  if (name.size() > 32) bad("is longer than 32 characters");
  if (!(name.front() >= 'a' && name.front() <= 'z')) bad("does not start with a lower-case letter");
  for (char c : name) {
    if (!lower_or_digit(c) && c != '_') bad(fmt::format("holds '{}'", c));
  }
  if (name.find("__") != std::string_view::npos) bad("holds '__'");
  if (name.back() == '_') bad("ends in '_'");
}

std::string derive_class_name(std::string_view name) {
  std::string out;
  bool start = true;
  for (char c : name) {
    if (c == '_') {
      start = true;
      continue;
    }
    out += start && c >= 'a' && c <= 'z' ? static_cast<char>(c - 'a' + 'A') : c;
    start = false;
  }
  return out;
}

// what: "InPort 'wrench'" or the port spec's text, for the message.
void check_port_name(std::string_view name, std::string_view what) {
  const auto bad = [&](std::string_view why) {
    throw std::invalid_argument(fmt::format(
        "{}: port name '{}' {}: use a C identifier of up to 64 of a-z A-Z 0-9 '_' starting with a lower-case "
        "letter (e.g. wrench)",
        what, name, why));
  };
  if (name.empty()) bad("is empty");
  if (name.size() > 64) bad("is longer than 64 characters");
  if (!(name.front() >= 'a' && name.front() <= 'z')) bad("does not start with a lower-case letter");
  for (char c : name) {
    if (!letter_or_digit(c) && c != '_') bad(fmt::format("holds '{}'", c));
  }
  // The generated members are <name>_in_ / <name>_out_: '__' there is reserved to the compiler.
  if (name.find("__") != std::string_view::npos) bad("holds '__'");
  if (name.back() == '_') bad("ends in '_'");
  if (reserved_port_names().count(name)) bad("is a C++ keyword or a macro");
}

// in<N> / out<N> also name ports by position (`rtm get c.in1`), and a port's own name wins:
// a port may be called so only when it is that position itself.
void check_index_alias(std::string_view name, bool is_in, std::size_t index) {
  for (std::string_view prefix : {"in", "out"}) {
    if (!name.starts_with(prefix) || name.size() == prefix.size()) continue;
    const auto digits = name.substr(prefix.size());
    if (digits.find_first_not_of("0123456789") != std::string_view::npos) continue;
    const std::string own = fmt::format("{}{}", is_in ? "in" : "out", index);
    if (name == own) return;
    throw std::invalid_argument(fmt::format(
        "{} '{}' is {} {}: in<N> and out<N> name ports by position, so '{}' would hide another port; "
        "call it {} or give it a name of its own",
        is_in ? "InPort" : "OutPort", name, is_in ? "InPort" : "OutPort", index, name, own));
  }
}

// =============================== the plan =============================

struct Port {
  std::string name;
  const TypeInfo* type;  // a built-in type; nullptr for one of the project's own IDL
  std::string own;       // that one's name: "My::TimedPose"
};

// An IDL file the project gets a copy of.
struct IdlFile {
  std::string file_name;  // "TimedPose.idl"
  std::string text;
};

// Everything the files are made from, checked.
struct Plan {
  std::string name;
  std::string class_name;
  std::string period;
  std::string description;  // one line, printable, without its final '.'
  std::vector<ParamSpec> params;
  std::vector<Port> in, out;
  std::vector<IdlFile> idl;
  std::vector<std::string> idl_types;  // the ports' own types the IDL files declare
  std::vector<std::string> packages;   // of types, found by find_package
  // For each OutPort, the InPort the generated step() passes to it (-1: none): the InPort of
  // the same type and the same rank among the ports of that type.
  std::vector<int> source_of;
};

std::string type_of(const Port& p) { return p.type ? full_name(*p.type) : p.own; }

std::vector<Port> checked_ports(const std::vector<PortSpec>& specs, bool is_in, std::set<std::string>& seen) {
  std::vector<Port> ports;
  for (std::size_t i = 0; i < specs.size(); ++i) {
    const auto what = fmt::format("{} '{}'", is_in ? "InPort" : "OutPort", specs[i].name);
    check_port_name(specs[i].name, what);
    const bool own = is_own_type_name(specs[i].type);
    const TypeInfo* type = own ? nullptr : &find_type(specs[i].type, what);
    if (!seen.insert(specs[i].name).second) {
      throw std::invalid_argument(fmt::format(
          "port name '{}' is given twice: each port needs a name of its own, InPorts and OutPorts alike "
          "(a port is found by its name)",
          specs[i].name));
    }
    check_index_alias(specs[i].name, is_in, i);
    ports.push_back({specs[i].name, type, own ? specs[i].type : ""});
  }
  return ports;
}

std::vector<int> pass_through_sources(const std::vector<Port>& in, const std::vector<Port>& out) {
  std::vector<int> sources;
  std::map<std::string, int> taken;  // OutPorts of a type seen so far
  for (const auto& o : out) {
    int rank = taken[type_of(o)]++;
    int source = -1;
    for (std::size_t i = 0; i < in.size() && source < 0; ++i) {
      if (type_of(in[i]) == type_of(o) && rank-- == 0) source = static_cast<int>(i);
    }
    sources.push_back(source);
  }
  return sources;
}

// One line of at most kMaxDescription printable characters (it becomes a C++ literal and a
// --help line), without the '.' that ends it.
constexpr std::size_t kMaxDescription = 300;
bool is_control(char c) { return static_cast<unsigned char>(c) < 0x20 || c == 0x7f; }
std::string checked_description(std::string text) {
  if (text.size() > kMaxDescription)
    throw std::invalid_argument(fmt::format("the description is {} characters long: one line of at most {}, please",
                                            text.size(), kMaxDescription));
  if (std::any_of(text.begin(), text.end(), is_control))
    throw std::invalid_argument("the description holds a control character (a line break, a tab...): one line "
                                "of text, please");
  while (!text.empty() && (text.back() == '.' || text.back() == ' ')) text.pop_back();
  return text;
}

// Text that goes into a C++ string literal as it is: printable, no quote, no backslash.
void check_literal_text(std::string_view text, std::string_view what) {
  if (std::any_of(text.begin(), text.end(), [](char c) { return is_control(c) || c == '"' || c == '\\'; }))
    throw std::invalid_argument(fmt::format("{} '{}' holds a quote, a backslash or a control character", what, text));
}

std::vector<ParamSpec> checked_params(std::vector<ParamSpec> params) {
  if (params.size() > rtm::kMaxParameters)
    throw std::invalid_argument(fmt::format("{} parameters: at most {}, please", params.size(), rtm::kMaxParameters));
  std::set<std::string> seen;
  for (auto& p : params) {
    check_port_name(p.name, fmt::format("parameter '{}'", p.name));
    if (!seen.insert(p.name).second) throw std::invalid_argument(fmt::format("parameter '{}' is given twice", p.name));
    check_literal_text(p.unit, fmt::format("parameter '{}': the unit", p.name));
    check_literal_text(p.description, fmt::format("parameter '{}': the description", p.name));
    if (!std::isfinite(p.default_value) || std::abs(p.default_value) > 3.4e38)
      throw std::invalid_argument(fmt::format("parameter '{}': the default must be a finite number a float holds", p.name));
    if (p.description.empty()) {
      p.description = p.name;
      std::replace(p.description.begin(), p.description.end(), '_', ' ');
    }
  }
  return params;
}

constexpr std::uintmax_t kMaxIdlBytes = 1 << 20;

IdlFile read_idl(const fs::path& path) {
  const std::string file_name = path.filename().string();
  const std::string stem = path.stem().string();
  if (path.extension() != ".idl" || stem.empty() ||
      !std::all_of(stem.begin(), stem.end(), identifier_char))
    throw std::invalid_argument(fmt::format(
        "--idl {}: name an IDL file <name>.idl, the name of a-z A-Z 0-9 '_' (its stubs are <name>.hh)", path.string()));
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) throw std::invalid_argument(fmt::format("--idl {}: {}", path.string(), ec.message()));
  if (size > kMaxIdlBytes)
    throw std::invalid_argument(fmt::format("--idl {}: {} bytes, more than an IDL file of types holds (1 MiB)",
                                            path.string(), size));
  std::FILE* file = std::fopen(path.c_str(), "rb");
  if (!file) throw std::invalid_argument(fmt::format("--idl {}: {}", path.string(), std::system_category().message(errno)));
  std::string text(size, '\0');
  const std::size_t got = std::fread(text.data(), 1, text.size(), file);
  std::fclose(file);
  text.resize(got);
  return {file_name, std::move(text)};
}

// The ports' own types: each declared, as a timed struct, by an --idl file, or left to a package.
void plan_own_types(const ScaffoldOptions& options, Plan& plan) {
  std::set<std::string> names;
  for (const auto& path : options.idl) {
    plan.idl.push_back(read_idl(path));
    if (!names.insert(plan.idl.back().file_name).second)
      throw std::invalid_argument(fmt::format("--idl: two files are called {}", plan.idl.back().file_name));
  }
  for (const auto& package : options.type_packages) {
    if (!is_idl_identifier(package))
      throw std::invalid_argument(fmt::format(
          "--types '{}': name a package of types by its CMake name, of a-z A-Z 0-9 '_' (e.g. pose_types)", package));
    if (std::find(plan.packages.begin(), plan.packages.end(), package) == plan.packages.end())
      plan.packages.push_back(package);
  }
  IdlStructs declared;
  for (const auto& file : plan.idl) {
    IdlStructs one = scan_idl(file.text);
    declared.timed.merge(one.timed);
    declared.untimed.merge(one.untimed);
  }
  std::string files;
  for (const auto& file : plan.idl) files += fmt::format("{}{}", files.empty() ? "" : ", ", file.file_name);
  for (const auto* ports : {&plan.in, &plan.out}) {
    for (const auto& port : *ports) {
      if (port.type) continue;
      const std::string what = fmt::format("port '{}': {}", port.name, port.own);
      if (plan.idl.empty() && plan.packages.empty())
        throw std::invalid_argument(fmt::format(
            "{} is a type of your own: name the IDL file that declares it (--idl FILE) or the package of types "
            "that holds it (--types PACKAGE)",
            what));
      if (declared.untimed.count(port.own))
        throw std::invalid_argument(fmt::format(
            "{} is declared in {} but is not timed: a port's datum starts with its stamp, `RTM::Time tm;` as its "
            "first member (#include \"RTM.idl\")",
            what, files));
      if (declared.timed.count(port.own)) {
        if (std::find(plan.idl_types.begin(), plan.idl_types.end(), port.own) == plan.idl_types.end())
          plan.idl_types.push_back(port.own);
      } else if (plan.packages.empty()) {
        throw std::invalid_argument(fmt::format("{}: no struct of that name in {} (a module per '::')", what, files));
      }
    }
  }
}

Plan make_plan(const ScaffoldOptions& options) {
  Plan plan;
  plan.name = options.name;
  plan.class_name = class_name_of(options.name);
  rtm::parse_period_ns(options.period);  // throws naming the text
  plan.period = options.period;
  plan.description = checked_description(options.description);
  plan.params = checked_params(options.params);
  std::set<std::string> seen;
  if (options.in.empty() && options.out.empty()) {
    plan.in = {{"in0", &kTypes[0], ""}};
    plan.out = {{"out0", &kTypes[0], ""}};
  } else {
    plan.in = checked_ports(options.in, true, seen);
    plan.out = checked_ports(options.out, false, seen);
  }
  if (options.python) {
    for (const auto* ports : {&plan.in, &plan.out})
      for (const auto& port : *ports)
        if (!port.type)
          throw std::invalid_argument(fmt::format("port '{}': a component in Python takes the built-in types only ({})",
                                                  port.name, known_types_text()));
    if (!options.idl.empty() || !options.type_packages.empty())
      throw std::invalid_argument("--idl and --types: a component in Python takes the built-in types only");
  }
  plan_own_types(options, plan);
  plan.source_of = pass_through_sources(plan.in, plan.out);
  return plan;
}

// ============================== templates =============================

using namespace scaffold_templates;  // kCMakeLists, kHeader, ...: templates/*.in

// Replaces each @KEY@ of text by values[KEY]. Templates hold no other '@'.
std::string substitute(std::string_view text, const std::map<std::string, std::string>& values) {
  std::string out;
  std::size_t at = 0;
  while (true) {
    const auto open = text.find('@', at);
    if (open == std::string_view::npos) break;
    const auto close = text.find('@', open + 1);
    if (close == std::string_view::npos) throw std::logic_error("scaffold template: unclosed @KEY@");
    const auto key = text.substr(open + 1, close - open - 1);
    const auto found = values.find(std::string(key));
    if (found == values.end()) throw std::logic_error(fmt::format("scaffold template: no value for @{}@", key));
    out.append(text.substr(at, open - at));
    out += found->second;
    at = close + 1;
  }
  out.append(text.substr(at));
  return out;
}

// ============================== rendering =============================

std::size_t name_width(const Plan& p) {
  std::size_t width = 0;
  for (const auto* ports : {&p.in, &p.out}) {
    for (const auto& port : *ports) width = std::max(width, port.name.size());
  }
  return width;
}

// "//   InPort 0   wrench  RTM::TimedFloat6" lines.
std::string port_table(const Plan& p) {
  std::string text;
  const auto width = name_width(p);
  for (std::size_t i = 0; i < p.in.size(); ++i) {
    text += fmt::format("//   InPort {}   {:<{}}  {}\n", i, p.in[i].name, width, type_of(p.in[i]));
  }
  for (std::size_t i = 0; i < p.out.size(); ++i) {
    text += fmt::format("//   OutPort {}  {:<{}}  {}\n", i, p.out[i].name, width, type_of(p.out[i]));
  }
  if (p.in.empty()) text += "//   no InPort: a source, computing every cycle\n";
  if (p.out.empty()) text += "//   no OutPort: a sink, acting on its inputs\n";
  return text;
}

std::string fields(const std::vector<Port>& ports, std::string_view none) {
  if (ports.empty()) return fmt::format("    // none: {}\n", none);
  std::string text;
  for (const auto& port : ports) text += fmt::format("    {} {}{{}};\n", type_of(port), port.name);
  return text;
}

std::string port_members(const Plan& p) {
  std::string text =
      "  // What each port carries, as `rtm cat` shows it: say it in your words, and name its values\n"
      "  // with their units, e.g. {\"the wrist wrench\", rtm::elements(\"fx fy fz tx ty tz\", \"N N N N·m N·m N·m\")}.\n";
  for (const auto& port : p.in) {
    text += fmt::format("  rtm::InPort<{0}>& {1}_in_ =\n"
                        "      add_in_port<{0}>(\"{1}\", {{\"the {0} it reads\", {{}}}});\n",
                        type_of(port), port.name);
  }
  for (const auto& port : p.out) {
    text += fmt::format("  rtm::OutPort<{0}>& {1}_out_ =\n"
                        "      add_out_port<{0}>(\"{1}\", {{\"the {0} it writes\", {{}}}});\n",
                        type_of(port), port.name);
  }
  return text;
}

// A float literal of value: "10.0f", "0.01f", "1e+06f".
std::string float_literal(double value) {
  std::string text = fmt::format("{:.9g}", static_cast<float>(value));
  if (text.find_first_of(".en") == std::string::npos) text += ".0";
  return text + "f";
}

// The parameters struct, one rtm::Param line each: the parameter's one declaration.
std::string params_declaration(const Plan& p) {
  if (p.params.empty()) return "";
  std::string text =
      "\n  // Its parameters, each declared once (rtm/parameters.h): its option and help, the check of a\n"
      "  // value, what `rtm cat` shows and `rtm set` changes (live: the next cycle uses it).\n"
      "  struct Params {\n";
  for (const auto& param : p.params) {
    text += fmt::format("    rtm::Param<float> {0}{{{1}, {{\"{0}\", \"{2}\", \"{3}\", rtm::ParameterAccess::live}}}};\n",
                        param.name, float_literal(param.default_value), param.unit, param.description);
  }
  return text + "  };\n  static const rtm::ParameterTable<Params>& parameters();\n";
}

// The headers that make the ports' own types port types (rtm_add_idl ... TYPES writes them).
std::string type_includes(const Plan& p) {
  std::string text;
  if (!p.idl_types.empty()) text += fmt::format("#include \"{}_types.h\"  // the types of idl/*.idl\n", p.name);
  for (const auto& package : p.packages) text += fmt::format("#include <{0}.h>  // the types of package {0}\n", package);
  return text;
}

std::string cmake_types(const Plan& p) {
  std::string text;
  if (!p.idl_types.empty()) {
    std::string files, types;
    for (const auto& f : p.idl) files += " idl/" + f.file_name;
    for (const auto& t : p.idl_types) types += " " + t;
    text += fmt::format("\n# The ports' own data types: stubs of idl/*.idl, and {0}_types.h, which makes them port types.\n"
                        "rtm_add_idl({0}_types FILES{1} TYPES{2})\n",
                        p.name, files, types);
  }
  if (!p.packages.empty()) {
    text += "\n# Packages of data types (installed by rtm_add_idl(... TYPES ... EXPORT)): <package>.h makes them port types.\n";
    for (const auto& package : p.packages) text += fmt::format("find_package({} REQUIRED)\n", package);
  }
  return text;
}

std::string cmake_type_links(const Plan& p) {
  std::string text;
  if (!p.idl_types.empty()) text += fmt::format(" {}_types", p.name);
  for (const auto& package : p.packages) text += fmt::format(" {0}::{0}", package);
  return text;
}

std::string render_header(const Plan& p) {
  const bool params = !p.params.empty();
  return substitute(kHeader,
                    {{"NAME", p.name},
                     {"TYPE_INCLUDES", type_includes(p)},
                     {"CLASS", p.class_name},
                     {"PORT_TABLE", port_table(p)},
                     {"INPUT_FIELDS", fields(p.in, "the component has no InPort")},
                     {"OUTPUT_FIELDS", fields(p.out, "the component has no OutPort")},
                     {"PARAMS_DECLARATION", params_declaration(p)},
                     {"STEP_PARAMS", params ? "const Params& params, " : ""},
                     {"CTOR_PARAMS", params ? fmt::format("  {}(std::string name, Params params);\n", p.class_name) : ""},
                     {"PARAMS_MEMBERS", params ? "  rtm::LiveValue<Params> params_live_;  // as `rtm set` leaves them\n"
                                                 "  Params params_;                       // the cycle's copy\n"
                                               : ""},
                     {"PORT_MEMBERS", port_members(p)}});
}

// on_cycle(): read every InPort, compute when something new came, write every OutPort.
std::string cycle_lines(const Plan& p) {
  std::string text;
  std::string any_new;
  const std::string params = p.params.empty() ? "" : "params_, ";
  if (!p.params.empty()) text += "  params_live_.take(params_);  // what `rtm set` published since, whole\n";
  if (p.in.empty()) {
    text += "  // No InPort: new outputs every cycle.\n";
  } else {
    text += "  // Each read takes the port's newest datum. Without a new one the outputs would only repeat\n"
            "  // the last ones: then nothing is written.\n";
    for (const auto& port : p.in) {
      text += fmt::format("  const bool new_{0} = {0}_in_.read(inputs_.{0}) == rtm::ReadResult::NewData;\n",
                          port.name);
      any_new += fmt::format("{}new_{}", any_new.empty() ? "" : " || ", port.name);
    }
    text += fmt::format("  if (!{}) return;\n", p.in.size() == 1 ? any_new : "(" + any_new + ")");
  }
  if (p.out.empty()) {
    text += "  // No OutPort: act on what step() computes here (a device, a file).\n"
            "  step(inputs_, " + params + "state_, rtm::now());\n";
    return text;
  }
  text += "  const Outputs out = step(inputs_, " + params + "state_, rtm::now());\n";
  for (const auto& port : p.out) text += fmt::format("  {0}_out_.write(out.{0});\n", port.name);
  return text;
}

std::string maybe_unused(bool unused) { return unused ? "[[maybe_unused]] " : ""; }

std::string render_source(const Plan& p) {
  std::string step_lines;
  bool uses_in = false;
  bool uses_now = false;
  for (std::size_t i = 0; i < p.out.size(); ++i) {
    const int source = p.source_of[i];
    if (source >= 0) {
      step_lines += fmt::format("  out.{} = in.{};\n", p.out[i].name, p.in[static_cast<std::size_t>(source)].name);
      uses_in = true;
    } else {
      step_lines += fmt::format("  out.{}.tm = now;\n", p.out[i].name);
      uses_now = true;
    }
  }
  const bool params = !p.params.empty();
  const std::string table =
      params ? fmt::format("\nconst rtm::ParameterTable<{0}::Params>& {0}::parameters() {{\n"
                           "  static const rtm::ParameterTable<Params> table{{\"{1}\"}};\n"
                           "  return table;\n}}\n\n"
                           "{0}::{0}(std::string name) : {0}(std::move(name), Params{{}}) {{}}\n",
                           p.class_name, p.name)
             : "";
  return substitute(
      kSource, {{"NAME", p.name},
                {"CLASS", p.class_name},
                {"IN_PARAMETER", maybe_unused(!uses_in) + "const Inputs& in"},
                {"PARAMS_PARAMETER", params ? "[[maybe_unused]] const Params& params, " : ""},
                {"NOW_PARAMETER", maybe_unused(!uses_now) + "const RTM::Time& now"},
                {"STEP_LINES", step_lines},
                {"PARAMS_DEFINITION", table},
                {"CTOR_PARAMS_DEFINITION", params ? ", Params params" : ""},
                {"CTOR_BODY", params ? "\n    , params_live_(params), params_(params) {\n"
                                       "  parameters().validate(params);\n"
                                       "  add_parameters(parameters(), params_live_);\n}"
                                     : " {}"},
                {"CYCLE_LINES", cycle_lines(p)}});
}

// text as adjacent string literals of about 80 characters at most, one per line.
std::string wrapped_literal(std::string_view text, std::string_view indent) {
  std::vector<std::string> lines{""};
  for (std::size_t at = 0; at < text.size();) {
    const auto space = text.find(' ', at);
    const auto word = text.substr(at, space == std::string_view::npos ? std::string_view::npos : space + 1 - at);
    if (!lines.back().empty() && lines.back().size() + word.size() > 80) lines.emplace_back();
    for (const char c : word) {
      if (c == '"' || c == '\\') lines.back() += '\\';
      lines.back() += c;
    }
    at += word.size();
  }
  std::string out;
  for (const auto& line : lines) out += fmt::format("{}{}\"{}\"", out.empty() ? "" : "\n", indent, line);
  return out;
}

// The --help line: what the component does, as its author said, and its ports.
std::string description(const Plan& p) {
  const auto list = [](const std::vector<Port>& ports) {
    std::string text;
    for (const auto& port : ports) text += fmt::format("{}{} {}", text.empty() ? "" : ", ", port.name, type_of(port));
    return text.empty() ? std::string("none") : text;
  };
  return wrapped_literal(
      fmt::format("rtm-{}: {}{}InPorts: {}; OutPorts: {}", p.name, p.description, p.description.empty() ? "" : ". ",
                  list(p.in), list(p.out)),
      "          ");
}

std::string render_main(const Plan& p) {
  const bool params = !p.params.empty();
  return substitute(
      kMain, {{"NAME", p.name},
              {"CLASS", p.class_name},
              {"DESCRIPTION", description(p)},
              {"MAIN_PARAMS",
               params ? fmt::format("  // One per component made (a module's members each have theirs): the defaults, then the options.\n"
                                    "  auto params = std::make_shared<{}::Params>();\n",
                                    p.class_name)
                      : ""},
              {"MAIN_PARAMS_OPTIONS",
               params ? fmt::format("      .add_options = [params](CLI::App& app) {{ rtm::add_parameter_options(app, {0}::parameters(), "
                                    "*params); }},\n"
                                    "      .validate = [params](const rtm::RunSettings&) {{ {0}::parameters().validate(*params); }},\n",
                                    p.class_name)
                      : ""},
              {"CREATE_CAPTURE", params ? "params" : ""},
              {"CREATE_PARAMS", params ? ", *params" : ""}});
}

// ---- the generated test: sample data per type ----

// The literal a test puts in value `index` (or the only value) of the k-th InPort: distinct
// per port, exact in a float.
std::string sample_value(const TypeInfo& t, std::size_t k, bool indexed) {
  if (t.element == "CORBA::Boolean") return "true";
  if (t.element == "CORBA::Long") return fmt::format("{}", 42 + k);
  if (indexed) return fmt::format("static_cast<{}>({} + i)", t.element, 10 * (k + 1));
  return fmt::format("{:.1f}{}", static_cast<double>(k) + 1.5, t.element == "float" ? "f" : "");
}

std::string expect_equal(const TypeInfo& t, const std::string& actual, const std::string& expected) {
  if (t.element == "CORBA::Boolean") {
    return fmt::format("EXPECT_{}({})", expected == "true" ? "TRUE" : "FALSE", actual);
  }
  if (t.element == "float") return fmt::format("EXPECT_FLOAT_EQ({}, {})", actual, expected);
  if (t.element == "double") return fmt::format("EXPECT_DOUBLE_EQ({}, {})", actual, expected);
  return fmt::format("EXPECT_EQ({}, {})", actual, expected);
}

constexpr int kSampleLength = 3;  // values a sequence sample holds

// Fills in.<port> with the k-th sample (stamp included).
std::string fill_sample(const Port& port, std::size_t k) {
  std::string text = fmt::format("  in.{}.tm = stamp({}, 500);\n", port.name, 101 + k);
  if (!port.type) return text;  // a type of the project's own: its stamp
  const TypeInfo& t = *port.type;
  const std::string var = fmt::format("in.{}.{}", port.name, t.field);
  switch (t.shape) {
    case Shape::scalar:
      return text + fmt::format("  {} = {};\n", var, sample_value(t, k, false));
    case Shape::array:
      return text + fmt::format("  for (CORBA::ULong i = 0; i < {}; ++i) {}[i] = {};\n", t.elements, var,
                                sample_value(t, k, true));
    case Shape::sequence:
      return text + fmt::format("  {0}.length({1});\n  for (CORBA::ULong i = 0; i < {1}; ++i) {0}[i] = {2};\n", var,
                                kSampleLength, sample_value(t, k, true));
  }
  return text;
}

// Expects out.<port> to hold the k-th sample (stamp included).
std::string expect_sample(const Port& port, std::size_t k) {
  std::string text =
      fmt::format("  EXPECT_EQ(out.{0}.tm.sec, {1}u);\n  EXPECT_EQ(out.{0}.tm.nsec, 500u);\n", port.name, 101 + k);
  if (!port.type) return text;
  const TypeInfo& t = *port.type;
  const std::string var = fmt::format("out.{}.{}", port.name, t.field);
  switch (t.shape) {
    case Shape::scalar:
      return text + fmt::format("  {};\n", expect_equal(t, var, sample_value(t, k, false)));
    case Shape::array:
      return text + fmt::format("  for (CORBA::ULong i = 0; i < {}; ++i) {};\n", t.elements,
                                expect_equal(t, var + "[i]", sample_value(t, k, true)));
    case Shape::sequence:
      return text + fmt::format("  ASSERT_EQ({0}.length(), {1}u);\n"
                                "  for (CORBA::ULong i = 0; i < {1}; ++i) {2};\n",
                                var, kSampleLength, expect_equal(t, var + "[i]", sample_value(t, k, true)));
  }
  return text;
}

// Expects out.<port> to hold zeros (an empty sequence) stamped 7 s 250 ns.
std::string expect_zero(const Port& port) {
  std::string text =
      fmt::format("  EXPECT_EQ(out.{0}.tm.sec, 7u);\n  EXPECT_EQ(out.{0}.tm.nsec, 250u);\n", port.name);
  if (!port.type) return text;
  const TypeInfo& t = *port.type;
  const std::string var = fmt::format("out.{}.{}", port.name, t.field);
  const std::string zero = t.element == "float"         ? "0.0f"
                           : t.element == "double"      ? "0.0"
                           : t.element == "CORBA::Long" ? "0"
                                                        : "false";
  switch (t.shape) {
    case Shape::scalar:
      return text + fmt::format("  {};\n", expect_equal(t, var, zero));
    case Shape::array:
      return text + fmt::format("  for (CORBA::ULong i = 0; i < {}; ++i) {};\n", t.elements,
                                expect_equal(t, var + "[i]", zero));
    case Shape::sequence:
      return text + fmt::format("  EXPECT_EQ({}.length(), 0u);\n", var);
  }
  return text;
}

// The parameters a test hands step(): their defaults.
std::string params_argument(const Plan& p) {
  return p.params.empty() ? "" : fmt::format("{}::Params{{}}, ", p.class_name);
}

// The State a test hands step(), declared before the call.
std::string state_declaration(const Plan& p) { return fmt::format("  {}::State state;\n", p.class_name); }

std::string pass_through_test(const Plan& p) {
  std::string fill;
  std::string expect;
  for (std::size_t i = 0; i < p.out.size(); ++i) {
    if (p.source_of[i] < 0) continue;
    const auto k = static_cast<std::size_t>(p.source_of[i]);
    fill += fill_sample(p.in[k], k);
    expect += expect_sample(p.out[i], k);
  }
  if (fill.empty()) return "";
  return fmt::format("\nTEST({0}Step, OutPortsCarryTheInPortOfTheirTypeWithItsStamp) {{\n"
                     "  {0}::Inputs in;\n{1}{4}"
                     "  const {0}::Outputs out = {0}::step(in, {3}state, stamp(7, 250));\n{2}}}\n",
                     p.class_name, fill, expect, params_argument(p), state_declaration(p));
}

std::string zero_test(const Plan& p) {
  std::string expect;
  for (std::size_t i = 0; i < p.out.size(); ++i) {
    if (p.source_of[i] < 0) expect += expect_zero(p.out[i]);
  }
  if (expect.empty()) return "";
  return fmt::format("\nTEST({0}Step, OutPortsWithoutAnInPortOfTheirTypeCarryZerosStampedNow) {{\n{3}"
                     "  const {0}::Outputs out = {0}::step({0}::Inputs{{}}, {2}state, stamp(7, 250));\n{1}}}\n",
                     p.class_name, expect, params_argument(p), state_declaration(p));
}

std::string render_test(const Plan& p) {
  std::string tests = pass_through_test(p) + zero_test(p);
  if (p.out.empty()) {
    tests = fmt::format("\n// No OutPort: step() returns nothing yet. Test what it computes once it does.\n"
                        "TEST({0}Step, HasNoOutputsToCompute) {{\n"
                        "  EXPECT_TRUE(std::is_empty_v<{0}::Outputs>);\n{2}"
                        "  EXPECT_NO_THROW({0}::step({0}::Inputs{{}}, {1}state, stamp(7, 250)));\n}}\n",
                        p.class_name, params_argument(p), state_declaration(p));
  }
  return substitute(kTest, {{"NAME", p.name}, {"CLASS", p.class_name}, {"TESTS", tests}});
}

// ---- the system file and the README ----

std::string render_system_file(const Plan& p) {
  const std::string example =
      p.in.empty() ? fmt::format("#   - name: other0\n#     command: [rtm-other]\n# connections:\n"
                                 "#   - {{from: {0}0.{1}, to: other0.in0}}\n",
                                 p.name, p.out.front().name)
                   : fmt::format("#   - name: other0\n#     command: [rtm-other]\n# connections:\n"
                                 "#   - {{from: other0.out0, to: {0}0.{1}}}\n",
                                 p.name, p.in.front().name);
  return substitute(kSystemFile,
                    {{"NAME", p.name},
                     {"PERIOD", p.period},
                     {"EXAMPLE", "# More components, and connections between their ports, e.g.:\n" + example}});
}

std::string render_readme(const Plan& p) {
  std::string ports = "| port | direction | type |\n| --- | --- | --- |\n";
  for (const auto& port : p.in) ports += fmt::format("| `{}` | in | `{}` |\n", port.name, type_of(port));
  for (const auto& port : p.out) ports += fmt::format("| `{}` | out | `{}` |\n", port.name, type_of(port));
  return substitute(kReadme, {{"NAME", p.name}, {"CLASS", p.class_name}, {"PERIOD", p.period}, {"PORT_LIST", ports}});
}

struct ProjectFile {
  fs::path relative;
  std::string text;
  bool executable = false;
};

std::vector<ProjectFile> render(const Plan& p) {
  std::vector<ProjectFile> files = {
      {"CMakeLists.txt",
       substitute(kCMakeLists, {{"NAME", p.name}, {"TYPES", cmake_types(p)}, {"TYPES_LINK", cmake_type_links(p)}})},
      {fs::path("include") / p.name / (p.name + ".h"), render_header(p)},
      {fs::path("src") / (p.name + ".cpp"), render_source(p)},
      {fs::path("src") / "main.cpp", render_main(p)},
      {fs::path("test") / (p.name + "_test.cpp"), render_test(p)},
      {p.name + ".yaml", render_system_file(p)},
      {"README.md", render_readme(p)},
      {".gitignore", "build/\n"},
  };
  for (const auto& idl : p.idl) files.insert(files.end() - 2, {fs::path("idl") / idl.file_name, idl.text});
  return files;
}

// ========================= a component in Python ======================

// Text inside a Python string literal: its quotes and backslashes escaped.
std::string python_text(std::string_view text) {
  std::string out;
  for (char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out;
}

// A float as Python writes one: "10.0", "0.01", "1e+06".
std::string python_float(double value) {
  std::string text = fmt::format("{}", value);
  if (text.find_first_of(".en") == std::string::npos) text += ".0";
  return text;
}

std::string python_port_specs(const std::vector<Port>& ports, const char* kind, const char* verb) {
  std::string text;
  for (const auto& port : ports)
    text += fmt::format("        \"{}\": rtm.{}(\"{}\", \"the {} it {}\"),\n", port.name, kind, port.type->name,
                        full_name(*port.type), verb);
  return text;
}

std::string python_param_specs(const Plan& p) {
  std::string text;
  for (const auto& param : p.params)
    text += fmt::format("        \"{}\": rtm.Parameter({}, unit=\"{}\", description=\"{}\"),\n", param.name,
                        python_float(param.default_value), param.unit, param.description);
  return text;
}

std::string python_compute_lines(const Plan& p) {
  std::string text;
  for (std::size_t k = 0; k < p.out.size(); ++k) {
    const Port& out = p.out[k];
    if (p.source_of[k] >= 0) {
      const Port& in = p.in[static_cast<std::size_t>(p.source_of[k])];
      text += fmt::format("    if inputs[\"{0}\"] is not None:\n"
                          "        outputs[\"{1}\"] = inputs[\"{0}\"]  # passed on as it came: the logic goes here\n",
                          in.name, out.name);
    } else {
      const TypeInfo& t = *out.type;
      text += fmt::format("    # outputs[\"{}\"] = ...  ({}: {})\n", out.name, full_name(t),
                          t.shape == Shape::sequence ? std::string("any number of values")
                          : t.elements == 1          ? std::string("one value")
                                                     : fmt::format("{} values", t.elements));
    }
  }
  if (p.out.empty()) text += "    # a sink: act on the inputs here\n";
  return text;
}

// The values of a sample datum of port k, as a numpy array literal.
std::string python_sample(const Port& port, std::size_t k) {
  const int count = port.type->shape == Shape::sequence ? 3 : port.type->elements;
  std::string values;
  for (int i = 0; i < count; ++i)
    values += fmt::format("{}{}", i ? ", " : "", port.type->element == "CORBA::Boolean" ? (i + k) % 2 : 10 * k + i + 1);
  return fmt::format("np.array([{}], dtype=float)", values);
}

std::string python_pass_test(const Plan& p) {
  if (std::none_of(p.source_of.begin(), p.source_of.end(), [](int s) { return s >= 0; })) return "";
  std::string inputs, checks;
  for (std::size_t i = 0; i < p.in.size(); ++i)
    inputs += fmt::format("{}\"{}\": {}", i ? ", " : "", p.in[i].name, python_sample(p.in[i], i + 1));
  for (std::size_t k = 0; k < p.out.size(); ++k) {
    if (p.source_of[k] < 0) continue;
    checks += fmt::format("    np.testing.assert_array_equal(outputs[\"{}\"], inputs[\"{}\"])\n", p.out[k].name,
                          p.in[static_cast<std::size_t>(p.source_of[k])].name);
  }
  return fmt::format("\n\ndef test_each_input_passes_on_to_the_output_of_its_type():\n"
                     "    inputs = {{{}}}\n"
                     "    outputs = compute(inputs, PARAMS)\n{}",
                     inputs, checks);
}

std::vector<ProjectFile> render_python(const Plan& p) {
  std::string defaults, none;
  for (const auto& param : p.params)
    defaults += fmt::format("{}\"{}\": {}", defaults.empty() ? "" : ", ", param.name, python_float(param.default_value));
  for (const auto& port : p.in) none += fmt::format("{}\"{}\": None", none.empty() ? "" : ", ", port.name);
  std::string ports = "| port | direction | type |\n| --- | --- | --- |\n";
  for (const auto& port : p.in) ports += fmt::format("| `{}` | in | `{}` |\n", port.name, type_of(port));
  for (const auto& port : p.out) ports += fmt::format("| `{}` | out | `{}` |\n", port.name, type_of(port));
  const std::string example = render_system_file(p);  // its example lines are the C++ project's
  const std::size_t from = example.find("# More components"), to = example.find("activate:");
  return {
      {p.name + ".py",
       substitute(kPyComponent, {{"NAME", p.name},
                                 {"CLASS", p.class_name},
                                 {"DESCRIPTION", python_text(p.description)},
                                 {"INPUT_SPECS", python_port_specs(p.in, "In", "reads")},
                                 {"OUTPUT_SPECS", python_port_specs(p.out, "Out", "writes")},
                                 {"PARAM_SPECS", python_param_specs(p)},
                                 {"COMPUTE_LINES", python_compute_lines(p)}}),
       true},
      {"test_" + p.name + ".py",
       substitute(kPyTest, {{"NAME", p.name},
                            {"CLASS", p.class_name},
                            {"PARAM_DEFAULTS", defaults},
                            {"NONE_INPUTS", none},
                            {"PASS_TEST", python_pass_test(p)}})},
      {p.name + ".yaml", substitute(kPySystemFile, {{"NAME", p.name},
                                                    {"PERIOD", p.period},
                                                    {"EXAMPLE", example.substr(from, to - from)}})},
      {"README.md", substitute(kPyReadme, {{"NAME", p.name}, {"PERIOD", p.period}, {"PORT_LIST", ports}})},
      {".gitignore", "__pycache__/\n"},
  };
}

// ============================== writing ===============================

// What one scaffold_component() call made, so that a failure can take it back.
class Writer {
 public:
  ~Writer() {
    if (committed_) return;
    std::error_code ignored;
    for (auto it = files_.rbegin(); it != files_.rend(); ++it) fs::remove(*it, ignored);
    for (auto it = folders_.rbegin(); it != folders_.rend(); ++it) fs::remove(*it, ignored);  // only when empty
  }

  // Makes folder and its missing ancestors.
  void make_folder(const fs::path& folder) {
    std::vector<fs::path> missing;
    std::error_code ignored;
    for (fs::path p = folder; !p.empty() && !fs::exists(p, ignored); p = p.parent_path()) {
      missing.insert(missing.begin(), p);
      if (p == p.parent_path()) break;
    }
    for (const auto& p : missing) {
      std::error_code ec;
      if (fs::create_directory(p, ec)) {
        folders_.push_back(p);
      } else if (ec) {
        throw std::runtime_error(fmt::format("cannot make the folder {}: {}", p.string(), ec.message()));
      }
    }
  }

  // Never replaces a file: "x" fails when path exists, even when it appeared since the check.
  void write_new(const fs::path& path, const std::string& text) {
    std::FILE* file = std::fopen(path.c_str(), "wx");
    if (!file) {
      throw std::runtime_error(
          fmt::format("cannot write {}: {}", path.string(), std::system_category().message(errno)));
    }
    files_.push_back(path);
    const bool written = std::fwrite(text.data(), 1, text.size(), file) == text.size();
    const int error = errno;
    if (std::fclose(file) != 0 || !written) {
      throw std::runtime_error(fmt::format("cannot write {}: {}", path.string(),
                                           std::system_category().message(written ? errno : error)));
    }
  }

  void commit() { committed_ = true; }

 private:
  std::vector<fs::path> files_;
  std::vector<fs::path> folders_;
  bool committed_ = false;
};

// The project goes into a new or empty folder only.
void check_target(const fs::path& folder) {
  std::error_code ec;
  const auto status = fs::status(folder, ec);
  if (status.type() == fs::file_type::not_found) return;
  if (ec) throw std::runtime_error(fmt::format("cannot look at {}: {}", folder.string(), ec.message()));
  if (!fs::is_directory(status)) {
    throw std::runtime_error(
        fmt::format("{} exists and is not a folder: choose another name or --dir", folder.string()));
  }
  const bool empty = fs::is_empty(folder, ec);
  if (ec) throw std::runtime_error(fmt::format("cannot look into {}: {}", folder.string(), ec.message()));
  if (!empty) {
    throw std::runtime_error(fmt::format(
        "{} already exists and is not empty: nothing in it is overwritten; choose another name or --dir",
        folder.string()));
  }
}

}  // namespace

const std::vector<std::string>& known_port_types() {
  static const std::vector<std::string> types = [] {
    std::vector<std::string> names;
    for (const auto& t : kTypes) names.push_back(full_name(t));
    return names;
  }();
  return types;
}

PortSpec parse_port_spec(std::string_view text) {
  const auto colon = text.find(':');
  if (colon == std::string_view::npos) {
    throw std::invalid_argument(fmt::format("port '{}' has no type: write name:Type, e.g. wrench:TimedFloat6", text));
  }
  const auto what = fmt::format("port '{}'", text);
  PortSpec spec{std::string(text.substr(0, colon)), ""};
  check_port_name(spec.name, what);
  const std::string_view type = text.substr(colon + 1);
  spec.type = is_own_type_name(type) ? std::string(type) : full_name(find_type(type, what));
  return spec;
}

ParamSpec parse_param_spec(std::string_view text) {
  std::vector<std::string_view> parts;
  std::size_t at = 0;
  while (parts.size() < 3) {
    const auto colon = text.find(':', at);
    if (colon == std::string_view::npos) break;
    parts.push_back(text.substr(at, colon - at));
    at = colon + 1;
  }
  parts.push_back(text.substr(at));  // the default, or the description after it
  if (parts.size() < 3)
    throw std::invalid_argument(fmt::format("parameter '{}': write name:unit:default[:description], e.g. cutoff_hz:Hz:10",
                                            text));
  ParamSpec spec{std::string(parts[0]), std::string(parts[1]), 0, parts.size() > 3 ? std::string(parts[3]) : ""};
  const std::string number(parts[2]);
  std::size_t used = 0;
  try {
    spec.default_value = std::stod(number, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (number.empty() || used != number.size())
    throw std::invalid_argument(fmt::format("parameter '{}': the default '{}' is not a number", text, number));
  checked_params({spec});  // the name, the texts and the number, as make_plan checks them
  return spec;
}

std::string class_name_of(std::string_view component_name) {
  check_component_name(component_name);
  std::string name = derive_class_name(component_name);
  // An all-capitals class name reads as a macro, and may be one ("a_b" -> AB).
  if (name.find_first_of("abcdefghijklmnopqrstuvwxyz") == std::string::npos) {
    throw std::invalid_argument(fmt::format(
        "component name '{}' makes the class name '{}', all capitals like a macro: use a word of two letters or "
        "more",
        component_name, name));
  }
  if (name == "Inputs" || name == "Outputs") {
    throw std::invalid_argument(fmt::format(
        "component name '{}' makes the class name '{}', which the class uses for its own struct: choose another",
        component_name, name));
  }
  return name;
}

std::vector<std::filesystem::path> scaffold_component(const ScaffoldOptions& options) {
  const Plan plan = make_plan(options);  // every check on the input, before anything is written
  const fs::path folder = (options.parent / options.name).lexically_normal();
  check_target(folder);
  const auto files = options.python ? render_python(plan) : render(plan);
  Writer writer;
  writer.make_folder(folder);
  std::vector<fs::path> written;
  for (const auto& file : files) {
    const fs::path path = folder / file.relative;
    writer.make_folder(path.parent_path());
    writer.write_new(path, file.text);
    if (file.executable) {
      std::error_code ec;
      fs::permissions(path, fs::perms::owner_exec | fs::perms::group_exec | fs::perms::others_exec,
                      fs::perm_options::add, ec);
      if (ec) throw std::runtime_error(fmt::format("cannot make {} executable: {}", path.string(), ec.message()));
    }
    written.push_back(path);
  }
  writer.commit();
  return written;
}

}  // namespace rtm::cli
