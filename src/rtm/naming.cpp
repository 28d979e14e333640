// SPDX-License-Identifier: Apache-2.0
#include "rtm/naming.h"

#include <fmt/format.h>
#include "rtm/log.h"
#include "rtm/orb.h"
#include <unistd.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <climits>
#include <cstdlib>
#include <map>

namespace rtm {

namespace {

constexpr const char* kHostKind = "host_cxt";
constexpr const char* kComponentKind = "rtc";
constexpr std::uint16_t kDefaultNamingPort = 2809;

CosNaming::Name one_name(const std::string& id, const char* kind) {
  CosNaming::Name name;
  name.length(1);
  name[0].id = CORBA::string_dup(id.c_str());
  name[0].kind = CORBA::string_dup(kind);
  return name;
}

CORBA::ULong to_millis(std::chrono::milliseconds ms) {
  return static_cast<CORBA::ULong>(std::clamp<long long>(ms.count(), 1, UINT_MAX));
}

}  // namespace

// ---- Values ----

NamingAddress NamingAddress::parse(std::string_view text) {
  NamingAddress address;
  std::string_view host = text;
  std::string_view port;
  if (!text.empty() && text.front() == '[') {
    const auto close = text.find(']');
    if (close == std::string_view::npos) {
      throw std::invalid_argument(fmt::format("naming address '{}': missing ']'", text));
    }
    host = text.substr(1, close - 1);
    const auto rest = text.substr(close + 1);
    if (!rest.empty()) {
      if (rest.front() != ':') {
        throw std::invalid_argument(fmt::format("naming address '{}': expected ':' after ']'", text));
      }
      port = rest.substr(1);
    }
  } else if (const auto colon = text.rfind(':'); colon != std::string_view::npos) {
    host = text.substr(0, colon);
    port = text.substr(colon + 1);
  }
  if (host.empty()) {
    throw std::invalid_argument(fmt::format("naming address '{}': empty host (want host:port)", text));
  }
  address.host = std::string(host);
  address.port = kDefaultNamingPort;
  if (!port.empty() || (text.size() > host.size() && text.back() == ':')) {
    unsigned value = 0;
    const auto [end, ec] = std::from_chars(port.data(), port.data() + port.size(), value);
    if (ec != std::errc{} || end != port.data() + port.size() || value == 0 || value > 65535) {
      throw std::invalid_argument(
          fmt::format("naming address '{}': port '{}' is not a number in 1..65535", text, port));
    }
    address.port = static_cast<std::uint16_t>(value);
  }
  return address;
}

NamingAddress NamingAddress::from_environment() {
  if (const char* env = std::getenv("RTM_NAMING"); env != nullptr && *env != '\0') {
    return parse(env);
  }
  return NamingAddress{};
}

std::string NamingAddress::to_string() const {
  if (host.find(':') != std::string::npos) return fmt::format("[{}]:{}", host, port);
  return fmt::format("{}:{}", host, port);
}

std::string NamingAddress::corbaloc() const {
  return fmt::format("corbaloc::{}/NameService", to_string());
}

void check_name(std::string_view name, std::string_view what) {
  const auto bad = [&](std::string_view why) {
    throw std::invalid_argument(fmt::format("{} '{}': {} (1 to 64 of A-Z a-z 0-9 _ - ., not starting with . or -)",
                                            what, name, why));
  };
  if (name.empty()) bad("empty");
  if (name.size() > 64) bad("longer than 64 characters");
  if (name.front() == '.' || name.front() == '-') bad("starts with '.' or '-'");
  for (char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
                    c == '-' || c == '.';
    if (!ok) bad(c == '/' ? "holds '/'" : "holds a character outside the rule");
  }
}

ComponentPath ComponentPath::parse(std::string_view text) {
  const auto slash = text.find('/');
  if (slash == std::string_view::npos) {
    if (text.empty()) throw std::invalid_argument("component name is empty");
    return ComponentPath{"", std::string(text)};
  }
  const auto host = text.substr(0, slash);
  const auto name = text.substr(slash + 1);
  if (host.empty() || name.empty() || name.find('/') != std::string_view::npos) {
    throw std::invalid_argument(
        fmt::format("component '{}': expected 'host/name' or 'name'", text));
  }
  return ComponentPath{std::string(host), std::string(name)};
}

ComponentPath ComponentPath::on_this_host(std::string name) {
  return ComponentPath{local_host_name(), std::move(name)};
}

std::string ComponentPath::to_string() const {
  return fmt::format("{}.{}/{}.{}", host, kHostKind, name, kComponentKind);
}

CosNaming::Name ComponentPath::to_name() const {
  CosNaming::Name path;
  path.length(2);
  path[0].id = CORBA::string_dup(host.c_str());
  path[0].kind = CORBA::string_dup(kHostKind);
  path[1].id = CORBA::string_dup(name.c_str());
  path[1].kind = CORBA::string_dup(kComponentKind);
  return path;
}

std::string local_host_name() {
  std::array<char, 256> buffer{};
  if (::gethostname(buffer.data(), buffer.size() - 1) != 0 || buffer[0] == '\0') {
    return "localhost";
  }
  return std::string(buffer.data());
}

// ---- NamingClient ----

NamingClient::NamingClient(CORBA::ORB_ptr orb, NamingAddress address,
                           std::chrono::milliseconds call_timeout)
    : orb_(CORBA::ORB::_duplicate(orb)), address_(std::move(address)), call_timeout_(call_timeout) {}

CosNaming::NamingContext_var NamingClient::root() const {
  // An unchecked narrow makes no remote call: the service may be down right now, and the
  // first real operation reports that with the address in the message.
  CORBA::Object_var object = orb_->string_to_object(address_.corbaloc().c_str());
  CosNaming::NamingContext_var context = CosNaming::NamingContext::_unchecked_narrow(object);
  omniORB::setClientCallTimeout(context, to_millis(call_timeout_));
  return context;
}

void NamingClient::throw_unreachable(const CORBA::SystemException& ex) const {
  throw NamingError(
      fmt::format("naming service at {} unreachable: {}", address_.to_string(), ex._name()));
}

template <class Call>
auto NamingClient::guarded(Call&& call) const -> decltype(call()) {
  try {
    return call();
  } catch (const CORBA::SystemException& ex) {
    throw_unreachable(ex);
  } catch (const CosNaming::NamingContext::InvalidName&) {
    throw NamingError(fmt::format("naming service at {}: invalid name", address_.to_string()));
  } catch (const CosNaming::NamingContext::CannotProceed&) {
    throw NamingError(fmt::format("naming service at {}: cannot proceed", address_.to_string()));
  } catch (const CORBA::UserException& ex) {
    throw NamingError(
        fmt::format("naming service at {}: unexpected {}", address_.to_string(), ex._name()));
  }
}

void NamingClient::bind(const ComponentPath& path, CORBA::Object_ptr object) const {
  guarded([&] {
    auto root_context = root();
    const auto host_name = one_name(path.host, kHostKind);
    CosNaming::NamingContext_var host_context;
    try {
      host_context = root_context->bind_new_context(host_name);
    } catch (const CosNaming::NamingContext::AlreadyBound&) {
      CORBA::Object_var existing = root_context->resolve(host_name);
      host_context = CosNaming::NamingContext::_narrow(existing);
      if (CORBA::is_nil(host_context)) {
        throw NamingError(fmt::format("naming service at {}: {}.{} is bound but is not a context",
                                      address_.to_string(), path.host, kHostKind));
      }
    }
    omniORB::setClientCallTimeout(host_context, to_millis(call_timeout_));
    host_context->rebind(one_name(path.name, kComponentKind), object);
  });
}

void NamingClient::unbind(const ComponentPath& path) const {
  guarded([&] {
    try {
      root()->unbind(path.to_name());
    } catch (const CosNaming::NamingContext::NotFound&) {
      // Already gone, e.g. the naming service restarted without its data: nothing to undo.
    }
  });
}

CORBA::Object_var NamingClient::resolve_object(const ComponentPath& path) const {
  return guarded([&]() -> CORBA::Object_var {
    try {
      return root()->resolve(path.to_name());
    } catch (const CosNaming::NamingContext::NotFound&) {
      throw NamingError(fmt::format("no component {} in naming service at {}", path.to_string(),
                                    address_.to_string()));
    }
  });
}

bool NamingClient::is_bound(const ComponentPath& path) const {
  return guarded([&] {
    try {
      CORBA::Object_var object = root()->resolve(path.to_name());
      return true;
    } catch (const CosNaming::NamingContext::NotFound&) {
      return false;
    }
  });
}

std::vector<ComponentEntry> NamingClient::list_components() const {
  return guarded([&] {
    auto root_context = root();
    std::vector<ComponentEntry> entries;

    // list(n) returns up to n bindings directly and the rest through an iterator.
    constexpr CORBA::ULong kBatch = 256;
    auto for_each_binding = [&](CosNaming::NamingContext_ptr context, auto&& visit) {
      CosNaming::BindingList_var batch;
      CosNaming::BindingIterator_var rest;
      context->list(kBatch, batch.out(), rest.out());
      for (CORBA::ULong i = 0; i < batch->length(); ++i) visit(batch[i]);
      if (CORBA::is_nil(rest)) return;
      omniORB::setClientCallTimeout(rest, to_millis(call_timeout_));
      while (rest->next_n(kBatch, batch.out())) {
        for (CORBA::ULong i = 0; i < batch->length(); ++i) visit(batch[i]);
      }
      rest->destroy();
    };

    for_each_binding(root_context, [&](const CosNaming::Binding& host_binding) {
      if (host_binding.binding_type != CosNaming::ncontext || host_binding.binding_name.length() != 1 ||
          std::string_view(host_binding.binding_name[0].kind) != kHostKind) {
        return;
      }
      const std::string host(host_binding.binding_name[0].id);
      CosNaming::NamingContext_var host_context;
      try {
        CORBA::Object_var object = root_context->resolve(host_binding.binding_name);
        host_context = CosNaming::NamingContext::_narrow(object);
      } catch (const CosNaming::NamingContext::NotFound&) {
        return;  // unbound between list and resolve
      }
      if (CORBA::is_nil(host_context)) return;
      omniORB::setClientCallTimeout(host_context, to_millis(call_timeout_));
      for_each_binding(host_context, [&](const CosNaming::Binding& binding) {
        if (binding.binding_type != CosNaming::nobject || binding.binding_name.length() != 1 ||
            std::string_view(binding.binding_name[0].kind) != kComponentKind) {
          return;
        }
        ComponentEntry entry{{host, std::string(binding.binding_name[0].id)}, {}};
        try {
          entry.object = host_context->resolve(binding.binding_name);
        } catch (const CosNaming::NamingContext::NotFound&) {
          return;
        }
        entries.push_back(std::move(entry));
      });
    });

    std::sort(entries.begin(), entries.end(), [](const auto& a, const auto& b) {
      return std::tie(a.path.host, a.path.name) < std::tie(b.path.host, b.path.name);
    });
    return entries;
  });
}

RTM::RtComponent_var NamingClient::resolve_component(std::string_view host_slash_name, ComponentPath* found) const {
  ComponentPath path;
  try {
    path = ComponentPath::parse(host_slash_name);
  } catch (const std::invalid_argument& ex) {
    throw NamingError(ex.what());
  }

  CORBA::Object_var object;
  if (!path.host.empty()) {
    object = resolve_object(path);
  } else {
    std::vector<ComponentEntry> matches;
    for (auto& entry : list_components()) {
      if (entry.path.name == path.name) matches.push_back(std::move(entry));
    }
    if (matches.empty()) {
      throw NamingError(fmt::format("no component named '{}' on any host in naming service at {}",
                                    path.name, address_.to_string()));
    }
    if (matches.size() > 1) {
      std::string hosts;
      for (const auto& match : matches) {
        hosts += hosts.empty() ? "" : ", ";
        hosts += match.path.host + "/" + match.path.name;
      }
      throw NamingError(fmt::format("component name '{}' is ambiguous, say which: {}", path.name, hosts));
    }
    path = matches.front().path;
    object = matches.front().object;
  }

  RTM::RtComponent_var component;
  try {
    component = RTM::RtComponent::_narrow(object);
  } catch (const CORBA::SystemException& ex) {
    throw NamingError(fmt::format("component {} bound in naming service at {} does not answer: {}",
                                  path.to_string(), address_.to_string(), ex._name()));
  }
  if (CORBA::is_nil(component)) {
    throw NamingError(fmt::format("{} in naming service at {} is not an RTM::RtComponent",
                                  path.to_string(), address_.to_string()));
  }
  if (process_hooks().membership_problem) check_member(path, component.in());
  if (found) *found = path;
  return component;
}

void NamingClient::check_member(const ComponentPath& path, CORBA::Object_ptr object) const {
  const auto& membership_problem = process_hooks().membership_problem;
  if (!membership_problem) return;
  const std::string problem = membership_problem(object, path.host);
  if (!problem.empty())
    throw NotAMember(fmt::format("{} in naming service at {} is not this system's: {}", path.to_string(),
                                 address_.to_string(), problem));
}

}  // namespace rtm
