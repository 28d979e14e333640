// SPDX-License-Identifier: Apache-2.0
// Components written in Python (rtm.Component, rtm.run): a C++ rtm::Component whose ports are
// typed ports of the built-in types and whose cycle calls the Python object's step(), run by the
// runner every C++ component runs on (host/runner.h). So it is named in the naming service,
// takes the same command line (period, phase, priority, contract, chains, --stamp-from), is
// described, set, wired and recorded as any other, and no tool can tell it from a C++ one.
//
// The GIL is taken for each call into Python alone (on_start, step, on_stop) and released
// while the runner waits; how long a cycle waited for it and how long step() held it are
// statistics (python.gil_wait_*, python.step_*). An exception from step() puts the component in
// COMPONENT_ERROR with Python's message and where it was raised, and its on_stop() runs.
#include "common.h"

#include "host/runner.h"
#include "rt/clock.h"
#include "rt/histogram.h"
#include "rt/schedule.h"
#include "rtm/component.h"
#include "rtm/data.h"
#include "rtm/describe.h"
#include "rtm/inport.h"
#include "rtm/outport.h"
#include "rtm/log.h"
#include "rtm/parameters.h"

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <limits>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace rtm::python {

namespace {

// ------------------------------------------------------------------ ports

// What a port of a Python component is, as its class declares it (rtm.In / rtm.Out).
struct PortSpec {
  std::string name, type;  // type without "RTM::"
  PortInfo info;

  static PortSpec of(const std::string& name, py::handle spec) {
    PortSpec s;
    s.name = name;
    s.type = py::str(spec.attr("type")).cast<std::string>();
    if (s.type.rfind("RTM::", 0) == 0) s.type = s.type.substr(5);
    const auto text = [&spec](const char* attribute) { return py::str(spec.attr(attribute)).cast<std::string>(); };
    const std::string names = text("elements");
    s.info = {text("description"), names.empty() ? std::vector<Element>{} : elements(names, text("units"))};
    return s;
  }
};

// The element names (units: false) or units (true) a port describes.
std::vector<std::string> element_texts(const PortInfo& info, bool units) {
  std::vector<std::string> out;
  for (const auto& e : info.elements) out.push_back(units ? e.unit : e.name);
  return out;
}

std::string builtin_type_names() {
  std::string out;
  for_each_builtin_type([&]<class T>() { out += (out.empty() ? "" : ", ") + std::string(DataTraits<T>::name.substr(5)); });
  return out;
}

// An InPort as Python reads it: read() gives the new datum, or None when none came.
class InSlot {
 public:
  virtual ~InSlot() = default;
  virtual py::object read() = 0;         // GIL held
  virtual py::object read_values() = 0;  // GIL held
  virtual InPortBase& port() = 0;
};

// An OutPort as Python writes it: write(values) with a Datum, a mapping of the port's element
// names, a sequence or numpy array of its values, or one number for a scalar type.
class OutSlot {
 public:
  virtual ~OutSlot() = default;
  virtual void write(py::handle values) = 0;  // GIL held
};

template <class T>
class TypedIn final : public InSlot {
 public:
  explicit TypedIn(InPort<T>& port)
      : port_(port), address_(port.full_name()), names_(element_texts(port.info(), false)),
        units_(element_texts(port.info(), true)) {}
  py::object read() override {
    if (port_.read(datum_) != ReadResult::NewData) return py::none();
    CORBA::Any any;
    DataTraits<T>::insert(any, datum_);
    return py::cast(Datum(std::move(any), address_, names_, units_));
  }
  // The values alone, straight from the datum: no Any, no Datum, no strings.
  py::object read_values() override {
    if (port_.read(datum_) != ReadResult::NewData) return py::none();
    using Traits = DataTraits<T>;
    const auto& v = Traits::values(datum_);
    if constexpr (Traits::shape == DataShape::scalar) {
      py::array_t<double> out(1);
      out.mutable_data()[0] = static_cast<double>(v);
      return out;
    } else {
      py::ssize_t n = 0;
      if constexpr (Traits::shape == DataShape::array)
        n = static_cast<py::ssize_t>(Traits::elements);
      else
        n = static_cast<py::ssize_t>(v.length());
      py::array_t<double> out(n);
      double* to = out.mutable_data();
      for (py::ssize_t i = 0; i < n; ++i) to[i] = static_cast<double>(v[static_cast<CORBA::ULong>(i)]);
      return out;
    }
  }
  InPortBase& port() override { return port_; }

 private:
  InPort<T>& port_;
  T datum_{};
  std::string address_;
  std::vector<std::string> names_, units_;
};

template <class T>
class TypedOut final : public OutSlot {
 public:
  explicit TypedOut(OutPort<T>& port)
      : port_(port), address_(port.full_name()), names_(element_texts(port.info(), false)) {}

  void write(py::handle values) override {
    bool stamped = false;
    if (py::isinstance<Datum>(values)) {
      const T* d = nullptr;
      const Datum& datum = values.cast<const Datum&>();
      if (!DataTraits<T>::extract(datum.any(), d))
        throw Error(fmt::format("{} carries {}: a {} datum does not fit", address_, DataTraits<T>::name, datum.type()));
      datum_ = *d;  // its stamp too: the sample it derives from
      stamped = true;
    } else {
      assign(numbers(values));
    }
    if constexpr (Stamped<T>) {
      if (!stamped) datum_.tm = rtm::now();
    }
    port_.write(datum_);
  }

 private:
  using Traits = DataTraits<T>;
  using Element = typename Traits::Element;

  // The values as doubles, in the port's order.
  std::vector<double> numbers(py::handle values) const {
    std::vector<double> out;
    if (py::isinstance<py::dict>(values)) {
      if (names_.empty()) throw Error(address_ + " does not name its elements: give its values in order");
      const auto d = py::reinterpret_borrow<py::dict>(values);
      for (const auto& item : d) {
        const auto key = py::str(item.first).cast<std::string>();
        if (std::find(names_.begin(), names_.end(), key) == names_.end())
          throw Error(fmt::format("{} has no element {}", address_, key));
      }
      for (const auto& n : names_) {
        if (!d.contains(n)) throw Error(fmt::format("{}: no value for {}", address_, n));
        out.push_back(py::cast<double>(d[py::str(n)]));
      }
      return out;
    }
    if (py::isinstance<py::str>(values)) throw Error(address_ + ": give numbers, not a string");
    if (!py::isinstance<py::iterable>(values)) return {py::cast<double>(values)};  // one number
    const auto array = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(values);
    if (!array || array.ndim() != 1) throw Error(address_ + ": give a flat sequence of numbers");
    out.assign(array.data(), array.data() + array.size());
    return out;
  }

  // Checked for the port's element type, then into datum_.
  void assign(const std::vector<double>& v) {
    constexpr std::size_t count = Traits::elements;
    if (count != 0 && v.size() != count)
      throw Error(fmt::format("{} ({}) takes {} values, got {}", address_, Traits::name, count, v.size()));
    for (std::size_t i = 0; i < v.size(); ++i) {
      if (!std::isfinite(v[i])) throw Error(fmt::format("{}: value {} is {}", address_, i, v[i]));
      if constexpr (std::is_same_v<Element, float>) {
        if (std::fabs(v[i]) > FLT_MAX) throw Error(fmt::format("{}: value {} = {} is beyond a float", address_, i, v[i]));
      } else if constexpr (std::is_integral_v<Element> && !std::is_same_v<Element, CORBA::Boolean>) {
        if (v[i] != std::trunc(v[i]) || v[i] < std::numeric_limits<Element>::min() ||
            v[i] > std::numeric_limits<Element>::max())
          throw Error(fmt::format("{}: value {} = {} is no {}", address_, i, v[i], Traits::element));
      }
    }
    auto& values = Traits::values(datum_);
    if constexpr (Traits::shape == DataShape::scalar) {
      values = static_cast<Element>(v[0]);
    } else if constexpr (Traits::shape == DataShape::array) {
      for (std::size_t i = 0; i < count; ++i) values[i] = static_cast<Element>(v[i]);
    } else {
      values.length(static_cast<CORBA::ULong>(v.size()));
      for (std::size_t i = 0; i < v.size(); ++i) values[static_cast<CORBA::ULong>(i)] = static_cast<Element>(v[i]);
    }
  }

  OutPort<T>& port_;
  T datum_{};
  std::string address_;
  std::vector<std::string> names_;
};

// ------------------------------------------------------------------ parameters

// A parameter of a Python component: numbers, set by `rtm set` (or the command line's
// --param NAME=VALUE) and read by Python with parameter(name).
struct ParameterSlot {
  std::string name;
  std::size_t count = 1;  // values it takes
  mutable std::mutex mu;
  std::vector<double> value;  // guarded by mu

  py::object get() const {
    std::lock_guard lock(mu);
    if (count == 1) return py::float_(value[0]);
    return py::cast(value);
  }
};

// ------------------------------------------------------------------ the component

struct CycleInfo {
  std::uint64_t number;
  std::int64_t deadline_ns, wake_ns, period_ns;
};

class PyComponent final : public Component {
 public:
  // GIL held.
  PyComponent(const std::string& name, const std::string& kind, const py::object& cls,
              const std::vector<std::pair<std::string, std::string>>& parameter_texts)
      : Component(name, kind) {
    instance_ = cls();
    py::dict inputs, outputs;
    for (const auto& item : py::reinterpret_borrow<py::dict>(cls.attr("inputs"))) {
      const auto spec = PortSpec::of(py::str(item.first).cast<std::string>(), item.second);
      inputs[py::str(spec.name)] = py::cast(add_in(spec), py::return_value_policy::reference);
    }
    for (const auto& item : py::reinterpret_borrow<py::dict>(cls.attr("outputs"))) {
      const auto spec = PortSpec::of(py::str(item.first).cast<std::string>(), item.second);
      outputs[py::str(spec.name)] = py::cast(add_out(spec), py::return_value_policy::reference);
    }
    for (const auto& item : py::reinterpret_borrow<py::dict>(cls.attr("parameters")))
      add_python_parameter(py::str(item.first).cast<std::string>(), item.second);
    for (const auto& [pname, text] : parameter_texts) set_parameter_text(pname, text);
    add_percentile_statistics("python.gil_wait", "a cycle waiting for the GIL", gil_wait_);
    add_percentile_statistics("python.step", "step() holding the GIL", step_time_);
    auto ns = py::module_::import("types").attr("SimpleNamespace");
    instance_.attr("name") = name;
    instance_.attr("inputs") = ns(**inputs);
    instance_.attr("outputs") = ns(**outputs);
    instance_.attr("_parameter") = py::cpp_function([this](const std::string& p) { return parameter(p); });
    step_ = instance_.attr("step");
    // numpy's C API is loaded at its first use: here, not in the first step (tens of ms).
    (void)py::array_t<double>(0);
  }
  ~PyComponent() override {
    py::gil_scoped_acquire gil;
    step_ = py::object();
    instance_ = py::object();
  }

  void on_start() override { call("on_start"); }
  void on_stop() override { call("on_stop"); }
  void on_cycle(const CycleContext& ctx) override {
    const std::int64_t asked = monotonic_ns();
    std::string failure;
    {
      py::gil_scoped_acquire gil;
      const std::int64_t taken = monotonic_ns();
      gil_wait_.record(taken - asked);
      try {
        step_(CycleInfo{ctx.cycle, ctx.deadline_ns, ctx.wake_ns, ctx.period_ns});
      } catch (py::error_already_set& e) {
        failure = e.what();
      }
      step_time_.record(monotonic_ns() - taken);
    }
    if (!failure.empty()) throw std::runtime_error("step() raised " + failure);
  }

  py::object parameter(const std::string& pname) const {
    for (const auto& p : parameters_)
      if (p->name == pname) return p->get();
    throw Error(fmt::format("{} has no parameter {}", name(), pname));
  }

 private:
  InSlot* add_in(const PortSpec& spec) {
    InSlot* slot = nullptr;
    for_each_builtin_type([&]<class T>() {
      if (slot == nullptr && DataTraits<T>::name.substr(5) == spec.type)
        slot = ins_.emplace_back(std::make_unique<TypedIn<T>>(add_in_port<T>(spec.name, spec.info))).get();
    });
    if (slot == nullptr) throw unknown_type(spec);
    return slot;
  }
  OutSlot* add_out(const PortSpec& spec) {
    OutSlot* slot = nullptr;
    for_each_builtin_type([&]<class T>() {
      if (slot == nullptr && DataTraits<T>::name.substr(5) == spec.type)
        slot = outs_.emplace_back(std::make_unique<TypedOut<T>>(add_out_port<T>(spec.name, spec.info))).get();
    });
    if (slot == nullptr) throw unknown_type(spec);
    return slot;
  }
  Error unknown_type(const PortSpec& spec) const {
    return Error(fmt::format("{}: port {}: no data type {} (the built-in ones: {})", name(), spec.name, spec.type,
                             builtin_type_names()));
  }

  void add_python_parameter(const std::string& pname, py::handle spec) {
    auto& slot = *parameters_.emplace_back(std::make_unique<ParameterSlot>());
    slot.name = pname;
    const py::object value = spec.attr("value");
    if (py::isinstance<py::iterable>(value)) {
      for (py::handle v : value) slot.value.push_back(py::cast<double>(v));
    } else {
      slot.value.push_back(py::cast<double>(value));
    }
    slot.count = slot.value.size();
    if (slot.count == 0) throw Error(fmt::format("{}: parameter {} has no value", name(), pname));
    const std::string access = py::str(spec.attr("access")).cast<std::string>();
    const ParameterAccess how = access == "live"       ? ParameterAccess::live
                                : access == "when off" ? ParameterAccess::when_off
                                : access == "fixed"    ? ParameterAccess::fixed
                                                       : throw Error(fmt::format(
                                                             "{}: parameter {}: access '{}': want live, when off or fixed",
                                                             name(), pname, access));
    add_parameter({.name = pname,
                   .unit = py::str(spec.attr("unit")).cast<std::string>(),
                   .description = py::str(spec.attr("description")).cast<std::string>(),
                   .access = how,
                   .get =
                       [&slot] {
                         std::lock_guard lock(slot.mu);
                         return format_numbers(std::span<const double>(slot.value));
                       },
                   .set = [&slot](std::string_view text) {
                     auto v = parse_numbers(text, slot.count);
                     std::lock_guard lock(slot.mu);
                     slot.value = std::move(v);
                   }});
  }
  void set_parameter_text(const std::string& pname, const std::string& text) {
    for (const auto& p : parameters()) {
      if (p.name != pname) continue;
      p.set(text);
      return;
    }
    throw std::invalid_argument(fmt::format("--param {}: {} has no such parameter", pname, name()));
  }

  void call(const char* method) {
    std::string failure;
    {
      py::gil_scoped_acquire gil;
      try {
        instance_.attr(method)();
      } catch (py::error_already_set& e) {
        failure = e.what();
      }
    }
    if (!failure.empty()) throw std::runtime_error(std::string(method) + "() raised " + failure);
  }

  py::object instance_, step_;
  std::vector<std::unique_ptr<InSlot>> ins_;
  std::vector<std::unique_ptr<OutSlot>> outs_;
  std::vector<std::unique_ptr<ParameterSlot>> parameters_;
  LatencyHistogram gil_wait_, step_time_;
};

// "NAME=VALUE" of --param.
std::pair<std::string, std::string> parameter_text(const std::string& text) {
  const std::size_t eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw std::invalid_argument("--param '" + text + "': want NAME=VALUE, e.g. gain=2 or gains=\"1 2 3\"");
  return {text.substr(0, eq), text.substr(eq + 1)};
}

// Runs cls as a component of this process until SIGINT/SIGTERM: the runner's exit status.
int run(const py::object& cls, const std::vector<std::string>& argv) {
  ComponentMain main;
  main.kind = py::str(cls.attr("kind")).cast<std::string>();
  main.description = py::str(cls.attr("description")).cast<std::string>();
  const std::string budget = py::str(cls.attr("budget")).cast<std::string>();
  if (!budget.empty()) {
    const auto ns = parse_duration_ns(budget);
    if (!ns || *ns <= 0) throw Error(fmt::format("{}.budget '{}': want a duration above 0, e.g. 0.3ms", main.kind, budget));
    main.budget_ns = static_cast<std::int64_t>(*ns);
  }
  auto texts = std::make_shared<std::vector<std::string>>();
  main.add_options = [texts](CLI::App& app) {
    app.add_option("--param", *texts, "NAME=VALUE: a parameter's value at start (repeatable; `rtm set` changes it later)")
        ->take_all();
  };
  // The class as a handle: no reference count is touched without the GIL (the caller keeps it).
  const py::handle cls_handle = cls;
  main.create = [cls_handle, texts](const RunSettings& settings) -> std::unique_ptr<Component> {
    std::vector<std::pair<std::string, std::string>> parameters;
    for (const auto& t : *texts) parameters.push_back(parameter_text(t));
    py::gil_scoped_acquire gil;
    try {
      const auto cls = py::reinterpret_borrow<py::object>(cls_handle);
      return std::make_unique<PyComponent>(settings.name, py::str(cls.attr("kind")).cast<std::string>(), cls,
                                           parameters);
    } catch (py::error_already_set& e) {
      throw std::runtime_error(std::string("making the component raised ") + e.what());
    }
  };
  // `import rtm` quiets the log to warnings for scripts; a component logs as a C++ one does.
  log().set_level(spdlog::level::info);
  std::vector<std::string> args = argv;
  std::vector<char*> pointers;
  for (auto& a : args) pointers.push_back(a.data());
  pointers.push_back(nullptr);
  py::gil_scoped_release release;
  return run_component(static_cast<int>(args.size()), pointers.data(), main);
}

}  // namespace

void bind_component(py::module_& m) {
  py::class_<InSlot>(m, "InPort", "an InPort of a Python component")
      .def("read", &InSlot::read, "the datum that came since the last read, or None")
      .def("read_values", &InSlot::read_values,
           "the values of the datum that came since the last read, as a numpy array, or None: what read().values "
           "gives, without making the Datum")
      .def(
          "expire_last", [](InSlot& slot) { slot.port().expire_last(); },
          "the component no longer acts on the last datum read() gave (it braked): a chain ending here counts no "
          "age and no stale cycle until read() gives a new one");
  py::class_<OutSlot>(m, "OutPort", "an OutPort of a Python component")
      .def("write", &OutSlot::write, py::arg("values"),
           "writes one datum: a Datum (its stamp kept), a mapping of the element names, a sequence or numpy array "
           "of the values, or one number (stamped now)");
  py::class_<CycleInfo>(m, "Cycle", "the cycle step() runs in")
      .def_readonly("number", &CycleInfo::number, "0, 1, 2, ... since on()")
      .def_readonly("deadline_ns", &CycleInfo::deadline_ns, "when it was due (CLOCK_MONOTONIC)")
      .def_readonly("wake_ns", &CycleInfo::wake_ns, "when the activity woke (CLOCK_MONOTONIC)")
      .def_readonly("period_ns", &CycleInfo::period_ns);
  m.def("_run", &run, py::arg("cls"), py::arg("argv"));
}

}  // namespace rtm::python
