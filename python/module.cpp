// SPDX-License-Identifier: Apache-2.0
// rtm._rtm: RTM from Python, through the C++ the `rtm` command line and the components run, so
// Python gets the same type checks, refusals, access screen and TLS, and the same words when it
// is refused: a running system (system.cpp) and components written in Python (component.cpp).
// python/rtm/__init__.py is the package around it; docs/python.md shows its use.
//
// Threads: every remote call runs with the GIL released; a Watch waits for data in slices, so
// Ctrl-C reaches Python while it waits. One ORB per process (omniORB has one): the first System
// makes it with its naming service's endpoints, its timeout and its TLS folder, and it lives
// until the process exits.
#include "common.h"
#include "rtm/log.h"

namespace rtm::python {
void bind_system(py::module_& m);
void bind_component(py::module_& m);
}  // namespace rtm::python

PYBIND11_MODULE(_rtm, m) {
  namespace rp = rtm::python;
  m.doc() = "RTM from Python, through the C++ core (docs/python.md)";
  rtm::log().set_level(spdlog::level::warn);
  pybind11::register_exception<rp::Error>(m, "Error", PyExc_RuntimeError);
  rp::bind_datum(m);
  rp::bind_system(m);
  rp::bind_component(m);
}
