// SPDX-License-Identifier: Apache-2.0
#include "common.h"

#include "browser/json.h"

#include <fmt/format.h>
#include <pybind11/stl.h>

namespace rtm::python {

namespace cli = rtm::cli;

std::string failure_text(const CORBA::Exception& e) { return cli::failure_text(e); }

py::object to_python(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null: return py::none();
    case nlohmann::json::value_t::boolean: return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer: return py::int_(j.get<long long>());
    case nlohmann::json::value_t::number_unsigned: return py::int_(j.get<unsigned long long>());
    case nlohmann::json::value_t::number_float: return py::float_(j.get<double>());
    case nlohmann::json::value_t::string: return py::str(j.get_ref<const std::string&>());
    case nlohmann::json::value_t::array: {
      py::list out;
      for (const auto& v : j) out.append(to_python(v));
      return out;
    }
    case nlohmann::json::value_t::object: {
      py::dict out;
      for (const auto& [k, v] : j.items()) out[py::str(k)] = to_python(v);
      return out;
    }
    default: return py::none();
  }
}

Datum::Datum(CORBA::Any value, std::string port, std::vector<std::string> names, std::vector<std::string> units)
    : value_(std::move(value)), port_(std::move(port)), names_(std::move(names)), units_(std::move(units)) {
  sample_ = cli::to_sample(value_);
}

std::vector<std::string> Datum::labels() const { return cli::value_labels(value_, names_); }

py::object Datum::fields() const {
  return to_python(cli::format_json(value_).value("fields", nlohmann::json::object()));
}

double Datum::at(const std::string& label) const {
  const auto all = labels();
  for (std::size_t i = 0; i < all.size() && i < sample_.values.size(); ++i)
    if (all[i] == label) return sample_.values[i];
  std::string known;
  for (const auto& l : all) known += (known.empty() ? "" : ", ") + l;
  throw py::key_error(fmt::format("{} has no value {} (it has {})", port_, label, known));
}

py::dict Datum::as_dict() const {
  py::dict d = to_python(cli::format_json(value_));
  d["port"] = port_;
  return d;
}

std::string Datum::text() const { return cli::format_text(value_, units_, names_); }

std::string word_of(py::handle item) {
  if (py::isinstance<py::bool_>(item)) return item.cast<bool>() ? "true" : "false";
  if (py::isinstance<py::str>(item)) return item.cast<std::string>();
  if (py::isinstance<py::int_>(item)) return py::str(item).cast<std::string>();
  if (py::hasattr(item, "__float__")) return fmt::format("{}", item.cast<double>());  // shortest exact text
  throw Error(fmt::format("{} is no number, boolean or string", py::repr(item).cast<std::string>()));
}

void bind_datum(py::module_& m) {
  py::class_<Datum>(m, "Datum", "one datum of a port")
      .def_property_readonly("port", &Datum::port, "the port it came from or went to, component.port")
      .def_property_readonly("type", &Datum::type, "its IDL type, e.g. RTM::TimedFloat6")
      .def_property_readonly("time_ns", &Datum::time_ns, "its stamp, ns since the epoch (CLOCK_REALTIME); 0: none")
      .def_property_readonly("values", &Datum::values, "its numbers in order, as a numpy array")
      .def_property_readonly("labels", &Datum::labels, "a label per number: the port's element names, or leaf paths")
      .def_property_readonly("units", &Datum::units, "a unit per element, as the port describes them")
      .def_property_readonly("fields", &Datum::fields, "its members after the stamp, by name, nested as declared")
      .def("__getitem__", &Datum::at, "a number by its label (an element name such as 'fz')")
      .def("as_dict", &Datum::as_dict, "as `rtm get --json` prints it")
      .def("__repr__", &Datum::text);

}

}  // namespace rtm::python
