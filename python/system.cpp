// SPDX-License-Identifier: Apache-2.0
// rtm.System, rtm.Port and rtm.Watch: a running system as the `rtm` command line sees it, through
// its browser and launcher.
#include "common.h"

#include "browser/browser.h"
#include "browser/json.h"
#include "browser/watch_port.h"
#include "host/access.h"
#include "host/tls.h"
#include "launcher/launcher.h"
#include "launcher/system_file.h"
#include "rtm/data.h"
#include "rtm/orb.h"

#include <fmt/format.h>
#include <pybind11/stl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <deque>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

namespace rtm::python {

namespace cli = rtm::cli;

namespace {

// ------------------------------------------------------------------ the process's ORB

struct OrbSettings {
  std::vector<std::string> args;
  std::string tls;
};

// The ORB of this process, made by the first caller's settings; later callers share it and
// must not ask for another TLS folder. It lives as long as the process: the access screen and
// the interceptors that tell which process serves an object are registered once per process,
// so a second ORB would run without them.
std::shared_ptr<rtm::Orb> process_orb(const OrbSettings& settings) {
  static std::mutex mu;
  static std::shared_ptr<rtm::Orb> current;
  static std::string current_tls;
  std::lock_guard lock(mu);
  if (current) {
    if (settings.tls != current_tls)
      throw Error(fmt::format("this process already talks to components {}; a System with tls={} needs a process of "
                              "its own (omniORB has one ORB per process)",
                              current_tls.empty() ? "without TLS" : "with TLS folder " + current_tls,
                              settings.tls.empty() ? "None" : settings.tls));
    return current;
  }
  if (!settings.tls.empty()) {
    rtm::configure_tls(rtm::check_tls_folder(settings.tls));
    ::setenv(rtm::kTlsFolderVariable, settings.tls.c_str(), 1);  // what System.up starts uses it too
  }
  rtm::configure_access(rtm::AccessPolicy::owner);  // a Watch's InPort: this user's data only
  current = std::make_shared<rtm::Orb>(settings.args);
  current_tls = settings.tls;
  return current;
}

// What a System, its Ports and Watches share: the ORB and one browser.
struct Session {
  std::shared_ptr<rtm::Orb> orb;
  rtm::NamingAddress naming;
  std::unique_ptr<cli::Browser> browser;
};

// ------------------------------------------------------------------ a port

class Port {
 public:
  Port(std::shared_ptr<Session> session, const std::string& address) : session_(std::move(session)) {
    port_ = released([&] { return session_->browser->port(cli::PortAddress::parse(address)); });
    if (port_.direction == cli::Direction::out)
      out_ = RTM::OutPort::_narrow(port_.object);
    else
      in_ = RTM::InPort::_narrow(port_.object);
  }
  const std::string& address() const { return port_.address; }
  std::string direction() const { return cli::to_string(port_.direction); }
  std::string type() const { return rtm::type_name(port_.type.in()); }
  std::vector<std::string> names() const { return port_.names(); }
  std::vector<std::string> units() const { return port_.units(); }

  Datum get() const {
    if (CORBA::is_nil(out_)) throw Error(port_.address + " is an InPort; get reads OutPorts");
    CORBA::Any value = released([&] {
      try {
        CORBA::Any_var v = out_->get();
        return CORBA::Any(v.in());
      } catch (const CORBA::BAD_INV_ORDER& e) {
        if (e.minor() == rtm::kMinorNoDataYet) throw Error(port_.address + " has no data yet");
        throw;
      }
    });
    return {std::move(value), port_.address, port_.names(), port_.units()};
  }

  // values: a Datum, a mapping of the port's element names, or a sequence (a numpy array too)
  // of one value per leaf. Returns the datum put.
  Datum put(py::handle values) const {
    if (CORBA::is_nil(in_)) throw Error(port_.address + " is an OutPort; put writes InPorts");
    CORBA::Any value;
    if (py::isinstance<Datum>(values)) {
      value = values.cast<const Datum&>().any();
    } else {
      std::vector<std::string> words = words_of(values);
      value = released([&] {
        try {
          return cli::parse_value(port_.type, words);
        } catch (const cli::ValueError& e) {
          throw Error(port_.address + ": " + e.what());
        }
      });
    }
    released([&] {
      try {
        in_->put(value);
      } catch (const CORBA::BAD_PARAM&) {
        // The InPort refused the datum: its own words (a wrong type names both types).
        RTM::InPortEx_var ex = RTM::InPortEx::_narrow(in_);
        CORBA::String_var why = CORBA::is_nil(ex) ? CORBA::string_dup("BAD_PARAM") : ex->last_error();
        throw Error(port_.address + " refused the datum: " + std::string(why.in()));
      }
    });
    return {std::move(value), port_.address, port_.names(), port_.units()};
  }

  // The floor a Python loop of get()/put() is compared with (bench/python): the same n calls
  // made from C++, each releasing and taking the GIL as a call from Python does. Seconds.
  double repeat_get(std::size_t n) const {
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < n; ++i) (void)get();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  double repeat_put(py::handle values, std::size_t n) const {
    const auto start = std::chrono::steady_clock::now();
    for (std::size_t i = 0; i < n; ++i) (void)put(values);
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }

  const cli::ResolvedPort& resolved() const { return port_; }
  const std::shared_ptr<Session>& session() const { return session_; }

 private:
  std::vector<std::string> words_of(py::handle values) const {
    std::vector<std::string> words;
    if (py::isinstance<py::dict>(values)) {
      const auto names = port_.names();
      if (names.empty())
        throw Error(port_.address + " does not name its elements: give its values in order, one per leaf");
      py::dict d = py::reinterpret_borrow<py::dict>(values);
      for (const auto& item : d) {
        const auto k = py::str(item.first).cast<std::string>();
        if (std::find(names.begin(), names.end(), k) == names.end()) {
          std::string known;
          for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
          throw Error(fmt::format("{} has no element {} (it has {})", port_.address, k, known));
        }
      }
      for (const auto& n : names) {
        if (!d.contains(n)) throw Error(fmt::format("{}: no value for {}", port_.address, n));
        words.push_back(word_of(d[py::str(n)]));
      }
      return words;
    }
    if (py::isinstance<py::str>(values)) throw Error(port_.address + ": give a sequence of values, not one string");
    for (py::handle item : values) words.push_back(word_of(item));
    return words;
  }

  std::shared_ptr<Session> session_;
  cli::ResolvedPort port_;
  RTM::OutPort_var out_;
  RTM::InPort_var in_;
};

// ------------------------------------------------------------------ watching a port

// An OutPort's data as they come: an iterator of Datum, bounded (capacity) so a Python loop
// that falls behind loses the oldest data it did not take, counted in dropped().
class Watch {
 public:
  Watch(std::shared_ptr<Port> port, std::size_t capacity) : port_(std::move(port)) {
    if (port_->direction() != "out") throw Error(port_->address() + " is an InPort; watch reads OutPorts");
    if (capacity == 0 || capacity > 1'000'000) throw Error(fmt::format("capacity {}: want 1 to 1000000 data", capacity));
    const cli::ResolvedPort& p = port_->resolved();
    subscription_ = released([&] {
      return std::make_unique<cli::WatchSubscription>(*port_->session()->orb, p.object.in(), p.type.in(), p.address,
                                                      fmt::format("rtm-python-{}", ::getpid()), capacity, "the watch");
    });
  }
  ~Watch() { close(); }

  // The next datum; None when timeout_s passed first (None: wait as long as it takes).
  std::optional<Datum> next(std::optional<double> timeout_s) {
    if (!subscription_) throw Error("the watch of " + port_->address() + " is closed");
    const auto until = std::chrono::steady_clock::now() +
                       std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                           std::chrono::duration<double>(timeout_s.value_or(0)));
    while (pending_.empty()) {
      std::vector<CORBA::Any> got;
      released([&] { subscription_->port().drain(got, std::chrono::milliseconds(50)); });
      for (auto& a : got) pending_.push_back(std::move(a));
      if (!pending_.empty()) break;
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();  // Ctrl-C while waiting
      if (timeout_s && std::chrono::steady_clock::now() >= until) return std::nullopt;
    }
    CORBA::Any value = std::move(pending_.front());
    pending_.pop_front();
    const cli::ResolvedPort& p = port_->resolved();
    return Datum(std::move(value), p.address, p.names(), p.units());
  }

  std::uint64_t received() const { return subscription_ ? subscription_->port().received() : received_at_close_; }
  // Lost here (the loop fell behind the watch's capacity) and by the publisher for it.
  std::uint64_t dropped() const {
    if (!subscription_) return dropped_at_close_;
    const auto publisher = released([&] { return subscription_->publisher_dropped(); });
    return subscription_->port().overflowed() + publisher.value_or(0);
  }
  std::uint64_t late() const { return subscription_ ? subscription_->port().late() : 0; }
  bool shared_memory() const { return subscription_ && subscription_->port().reads_ring(); }
  void close() {
    if (!subscription_) return;
    received_at_close_ = subscription_->port().received();
    dropped_at_close_ = subscription_->port().overflowed();
    py::gil_scoped_release release;
    subscription_.reset();  // unsubscribes, deactivates; a publisher gone is no error here
  }
  const std::string& address() const { return port_->address(); }

 private:
  std::shared_ptr<Port> port_;
  std::unique_ptr<cli::WatchSubscription> subscription_;
  std::deque<CORBA::Any> pending_;
  std::uint64_t received_at_close_ = 0, dropped_at_close_ = 0;
};

// ------------------------------------------------------------------ the system

class System {
 public:
  System(std::optional<std::string> naming, std::optional<std::string> tls, double timeout_s) {
    if (!(timeout_s > 0) || timeout_s > 3600) throw Error(fmt::format("timeout {} s: want above 0, at most 3600", timeout_s));
    session_ = std::make_shared<Session>();
    try {
      session_->naming = naming ? rtm::NamingAddress::parse(*naming) : rtm::NamingAddress::from_environment();
    } catch (const std::invalid_argument& e) {
      throw Error(e.what());
    }
    const int timeout_ms = static_cast<int>(timeout_s * 1000);
    OrbSettings settings{cli::client_orb_arguments(session_->naming, tls.has_value(), timeout_ms), tls.value_or("")};
    session_->orb = released([&] { return process_orb(settings); });
    session_->browser =
        std::make_unique<cli::Browser>(session_->orb->orb(), session_->naming, std::chrono::milliseconds(timeout_ms));
  }

  std::string naming() const { return session_->naming.to_string(); }

  std::vector<std::string> components(const std::string& filter) const {
    const auto list = released([&] { return browser().list(filter, cli::Browser::Detail::brief); });
    std::vector<std::string> names;
    for (const auto& c : list)
      if (c.liveness == cli::Liveness::alive) names.push_back(c.path.name);
    return names;
  }
  py::list ls(const std::string& filter, bool detailed) const {
    const auto list = released([&] { return browser().list(filter, detailed); });
    py::list out;
    for (const auto& c : list) out.append(to_python(cli::component_json(c, detailed)));
    return out;
  }
  py::object describe(const std::string& name) const {
    const auto info = released([&] { return browser().describe(name); });
    return to_python(cli::component_json(info, true));
  }
  void switch_component(const std::string& name, cli::Switch what) const {
    released([&] { browser().switch_component(name, what); });
  }
  std::string set(const std::string& name, const std::string& parameter, py::handle value) const {
    std::string text;
    if (py::isinstance<py::str>(value) || !py::isinstance<py::iterable>(value)) {
      text = word_of(value);
    } else {
      for (py::handle item : value) text += (text.empty() ? "" : " ") + word_of(item);
    }
    return released([&] { return browser().set_parameter(name, parameter, text); });
  }
  void connect(const std::string& out, const std::string& in, const std::string& policy, bool once) const {
    released([&] {
      const rtm::ConnPolicy p = rtm::parse_conn_policy(policy, once ? std::optional<bool>(true) : std::nullopt);
      browser().connect(cli::PortAddress::parse(out), cli::PortAddress::parse(in), p);
    });
  }
  void disconnect(const std::string& out, const std::string& in, bool once) const {
    released([&] {
      browser().disconnect(cli::PortAddress::parse(out), cli::PortAddress::parse(in), once ? RTM::once : RTM::repeated);
    });
  }

  // A port resolved once: get/put through it make one call each.
  std::shared_ptr<Port> port(const std::string& address) {
    std::lock_guard lock(ports_mu_);
    auto& p = ports_[address];
    if (!p) p = std::make_shared<Port>(session_, address);
    return p;
  }
  // get/put by address: through the port resolved before; resolved again once when the
  // component it led to is gone (restarted under the same name).
  Datum get(const std::string& address) {
    return again_if_gone(address, [](const Port& p) { return p.get(); });
  }
  Datum put(const std::string& address, py::handle values) {
    return again_if_gone(address, [values](const Port& p) { return p.put(values); });
  }

  py::dict up(const std::string& file, const std::string& parameter_set, bool force, double timeout_s) const {
    const auto state = released([&] {
      const cli::SystemFile system = cli::SystemFile::load(file);
      cli::LaunchOptions launch;
      launch.bind_timeout = std::chrono::milliseconds(static_cast<long>(timeout_s * 1000));
      launch.parameter_set = parameter_set;
      launch.force = force;
      return cli::system_up(system, browser(), session_->naming, launch);
    });
    py::list processes;
    for (const auto& p : state.processes) {
      py::dict d;
      d["name"] = p.name;
      d["pid"] = p.pid;
      d["log"] = p.log.string();
      d["members"] = p.members;
      processes.append(d);
    }
    py::dict out;
    out["system"] = state.system;
    out["processes"] = processes;
    return out;
  }
  std::vector<std::string> down(const std::string& what) const {
    return released([&] {
      std::string name = what;
      if (std::filesystem::is_regular_file(what)) name = cli::SystemFile::load(what).name;
      const cli::SystemState state = cli::SystemState::load(name);
      return cli::system_down(state, &browser(), cli::LaunchOptions{});
    });
  }

 private:
  const cli::Browser& browser() const { return *session_->browser; }

  template <class F>
  Datum again_if_gone(const std::string& address, F&& f) {
    const std::shared_ptr<Port> p = port(address);
    try {
      return f(*p);
    } catch (const Error& e) {
      const std::string why = e.what();
      if (why != "TRANSIENT" && why != "OBJECT_NOT_EXIST" && why != "COMM_FAILURE") throw;
    }
    {
      std::lock_guard lock(ports_mu_);
      ports_.erase(address);
    }
    return f(*port(address));
  }

  std::shared_ptr<Session> session_;
  std::mutex ports_mu_;
  std::map<std::string, std::shared_ptr<Port>> ports_;
};

}  // namespace

void bind_system(py::module_& m) {
  py::class_<Port, std::shared_ptr<Port>>(m, "Port", "a port, resolved once: get/put make one call each")
      .def_property_readonly("address", &Port::address)
      .def_property_readonly("direction", &Port::direction, "'in' or 'out'")
      .def_property_readonly("type", &Port::type, "its IDL type, e.g. RTM::TimedFloat6")
      .def_property_readonly("names", &Port::names, "its elements' names, as it describes them")
      .def_property_readonly("units", &Port::units, "its elements' units")
      .def("get", &Port::get, "the OutPort's latest datum")
      .def("put", &Port::put, py::arg("values"), "puts one datum into the InPort; returns it")
      .def("_repeat_get", &Port::repeat_get, py::arg("n"), "n get() from C++: seconds (a benchmark's floor)")
      .def("_repeat_put", &Port::repeat_put, py::arg("values"), py::arg("n"), "n put() from C++: seconds");

  py::class_<Watch>(m, "Watch", "an OutPort's data as they come")
      .def("next", &Watch::next, py::arg("timeout") = py::none(),
           "the next datum; None when timeout (s) passed first; no timeout: waits as long as it takes")
      .def_property_readonly("received", &Watch::received)
      .def_property_readonly("dropped", &Watch::dropped, "data lost: this loop fell behind, or the publisher dropped")
      .def_property_readonly("late", &Watch::late)
      .def_property_readonly("shared_memory", &Watch::shared_memory, "reads the publisher's shared-memory ring")
      .def_property_readonly("address", &Watch::address)
      .def("close", &Watch::close, "unsubscribes; idempotent");

  py::class_<System>(m, "System", "the components of one naming service")
      .def(py::init<std::optional<std::string>, std::optional<std::string>, double>(), py::arg("naming") = py::none(),
           py::arg("tls") = py::none(), py::arg("timeout") = 5.0)
      .def_property_readonly("naming", &System::naming)
      .def("components", &System::components, py::arg("filter") = "", "the names of the live components")
      .def("ls", &System::ls, py::arg("filter") = "", py::arg("long") = false, "as `rtm ls [-l] --json`")
      .def("describe", &System::describe, py::arg("component"), "as `rtm cat --json`")
      .def("on", [](const System& s, const std::string& n) { s.switch_component(n, cli::Switch::on); })
      .def("off", [](const System& s, const std::string& n) { s.switch_component(n, cli::Switch::off); })
      .def("reset", [](const System& s, const std::string& n) { s.switch_component(n, cli::Switch::reset); })
      .def("set", &System::set, py::arg("component"), py::arg("parameter"), py::arg("value"),
           "sets a parameter; returns the value the component reports")
      .def("connect", &System::connect, py::arg("out"), py::arg("in_"), py::arg("policy") = "", py::arg("once") = false)
      .def("disconnect", &System::disconnect, py::arg("out"), py::arg("in_"), py::arg("once") = false)
      .def("port", &System::port, py::arg("address"))
      .def("get", &System::get, py::arg("address"))
      .def("put", &System::put, py::arg("address"), py::arg("values"))
      .def("_watch", [](System& s, const std::string& address, std::size_t capacity) {
        return std::make_unique<Watch>(s.port(address), capacity);
      }, py::arg("address"), py::arg("capacity"))
      .def("up", &System::up, py::arg("file"), py::arg("set") = "", py::arg("force") = false, py::arg("timeout") = 10.0)
      .def("down", &System::down, py::arg("system"), "stops a system `up` started; returns those killed");
}

}  // namespace rtm::python
