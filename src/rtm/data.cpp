// SPDX-License-Identifier: Apache-2.0
#include "rtm/data.h"

#include <pwd.h>
#include <time.h>
#include <unistd.h>

namespace rtm {

RTM::Time now() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  RTM::Time t;
  t.sec = static_cast<CORBA::ULong>(ts.tv_sec);
  t.nsec = static_cast<CORBA::ULong>(ts.tv_nsec);
  return t;
}

std::int64_t to_ns(const RTM::Time& t) {
  return static_cast<std::int64_t>(t.sec) * 1'000'000'000 + static_cast<std::int64_t>(t.nsec);
}

RTM::Time from_ns(std::int64_t ns) {
  RTM::Time t;
  t.sec = static_cast<CORBA::ULong>(ns / 1'000'000'000);
  t.nsec = static_cast<CORBA::ULong>(ns % 1'000'000'000);
  return t;
}

namespace {
const char* basic_kind_name(CORBA::TCKind kind) {
  switch (kind) {
    case CORBA::tk_null: return "null";
    case CORBA::tk_void: return "void";
    case CORBA::tk_short: return "short";
    case CORBA::tk_long: return "long";
    case CORBA::tk_ushort: return "unsigned short";
    case CORBA::tk_ulong: return "unsigned long";
    case CORBA::tk_float: return "float";
    case CORBA::tk_double: return "double";
    case CORBA::tk_boolean: return "boolean";
    case CORBA::tk_char: return "char";
    case CORBA::tk_octet: return "octet";
    case CORBA::tk_any: return "any";
    case CORBA::tk_TypeCode: return "TypeCode";
    case CORBA::tk_string: return "string";
    case CORBA::tk_longlong: return "long long";
    case CORBA::tk_ulonglong: return "unsigned long long";
    case CORBA::tk_longdouble: return "long double";
    case CORBA::tk_wchar: return "wchar";
    case CORBA::tk_wstring: return "wstring";
    case CORBA::tk_sequence: return "sequence";
    case CORBA::tk_array: return "array";
    default: return nullptr;
  }
}
}  // namespace

std::string type_name(CORBA::TypeCode_ptr tc) {
  if (CORBA::is_nil(tc)) return "<nil>";
  if (const char* basic = basic_kind_name(tc->kind())) return basic;
  std::string id;
  try {
    id = tc->id();
  } catch (const CORBA::TypeCode::BadKind&) {
    return "<unnamed type>";
  }
  // "IDL:RTM/TimedFloat6:1.0" -> "RTM::TimedFloat6"
  if (id.rfind("IDL:", 0) == 0) {
    std::string body = id.substr(4, id.rfind(':') - 4);
    std::string out;
    for (char c : body) {
      if (c == '/') out += "::";
      else out += c;
    }
    return out;
  }
  return id.empty() ? std::string("<unnamed type>") : id;
}

namespace {
template <class Range>
bool any_non_finite(const Range& values, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i)
    if (!std::isfinite(values[i])) return true;
  return false;
}
}  // namespace

bool has_non_finite(const RTM::TimedFloat6& d) { return any_non_finite(d.val, 6); }
bool has_non_finite(const RTM::TimedFloat3& d) { return any_non_finite(d.val, 3); }
bool has_non_finite(const RTM::TimedFloatSeq& d) { return any_non_finite(d.data, d.data.length()); }
bool has_non_finite(const RTM::TimedDoubleSeq& d) { return any_non_finite(d.data, d.data.length()); }

std::string access_refusal_text(std::uint32_t minor) {
  if (minor == kCallerUnknownMinor)
    return "not allowed: only the user who started it may change it, and over plain TCP from another host it "
           "cannot tell who calls (from another host: --tls with a certificate of its system; docs/safety.md)";
  const passwd* pw = ::getpwuid(::geteuid());
  const std::string user = pw && pw->pw_name ? pw->pw_name : "uid " + std::to_string(::geteuid());
  return "not allowed: only the user who started it may change it (this process runs as " + user +
         "; docs/safety.md)";
}

}  // namespace rtm
