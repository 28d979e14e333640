// SPDX-License-Identifier: Apache-2.0
// What the parts of rtm._rtm share: the Python exception of every refusal (rtm.Error), calls
// with the GIL released, one datum of a port (rtm.Datum), JSON and values between C++ and
// Python.
#pragma once

#include "browser/values.h"

#include <nlohmann/json.hpp>
#include <omniORB4/CORBA.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace rtm::python {

namespace py = pybind11;

// Every refusal and failure, with rtm's own words: rtm.Error in Python.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// The text `rtm` prints for a failed remote call.
std::string failure_text(const CORBA::Exception& e);

// Runs f with the GIL released; what it throws becomes an Error with the text `rtm` prints.
template <class F>
auto released(F&& f) -> decltype(f()) {
  try {
    py::gil_scoped_release release;
    return f();
  } catch (const Error&) {
    throw;
  } catch (const CORBA::Exception& e) {
    throw Error(failure_text(e));
  } catch (const std::exception& e) {
    throw Error(e.what());
  }
}

// JSON (the browser's results) as Python objects.
py::object to_python(const nlohmann::json& j);

// One datum of a port: its values by the port's element names and as a numpy array, its
// fields as the type declares them, its stamp.
class Datum {
 public:
  Datum(CORBA::Any value, std::string port, std::vector<std::string> names, std::vector<std::string> units);
  const CORBA::Any& any() const { return value_; }
  const std::string& port() const { return port_; }
  const std::string& type() const { return sample_.type; }
  long long time_ns() const { return sample_.time_ns; }
  py::array_t<double> values() const { return py::array_t<double>(py::ssize_t(sample_.values.size()), sample_.values.data()); }
  std::vector<std::string> labels() const;
  const std::vector<std::string>& units() const { return units_; }
  py::object fields() const;
  // A number by its label; KeyError listing the labels when there is none such.
  double at(const std::string& label) const;
  py::dict as_dict() const;  // as `rtm get --json` prints it
  std::string text() const;

 private:
  CORBA::Any value_;
  std::string port_;
  std::vector<std::string> names_, units_;
  rtm::cli::Sample sample_;
};

// A Python value as the word `rtm put` takes for one leaf. Error for anything else.
std::string word_of(py::handle item);
// The Datum class (rtm.Datum) registered in m.
void bind_datum(py::module_& m);

}  // namespace rtm::python
