// SPDX-License-Identifier: Apache-2.0
#include "rtm/data.h"

#include <optional>

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
// The numbers in a value of tc, or nullopt when it holds a sequence (any number of them).
std::optional<std::size_t> numbers_in(CORBA::TypeCode_ptr tc, bool top) {
  CORBA::TypeCode_var t = CORBA::TypeCode::_duplicate(tc);
  while (t->kind() == CORBA::tk_alias) t = t->content_type();
  switch (t->kind()) {
    case CORBA::tk_struct: {
      std::size_t n = 0;
      for (CORBA::ULong i = 0; i < t->member_count(); ++i) {
        if (top && i == 0 && std::string_view(t->member_name(i)) == "tm") continue;  // the stamp
        CORBA::TypeCode_var member = t->member_type(i);
        const auto m = numbers_in(member, false);
        if (!m) return std::nullopt;
        n += *m;
      }
      return n;
    }
    case CORBA::tk_array: {
      CORBA::TypeCode_var element = t->content_type();
      const auto m = numbers_in(element, false);
      if (!m) return std::nullopt;
      return *m * t->length();
    }
    case CORBA::tk_sequence: return std::nullopt;
    case CORBA::tk_short: case CORBA::tk_ushort: case CORBA::tk_long: case CORBA::tk_ulong:
    case CORBA::tk_longlong: case CORBA::tk_ulonglong: case CORBA::tk_float: case CORBA::tk_double:
    case CORBA::tk_boolean: case CORBA::tk_octet: case CORBA::tk_char: case CORBA::tk_wchar:
    case CORBA::tk_enum:
      return 1;
    default: return 0;  // a string, or a kind that is no number
  }
}
}  // namespace

std::size_t count_values(CORBA::TypeCode_ptr tc) {
  if (CORBA::is_nil(tc)) return 0;
  return numbers_in(tc, true).value_or(0);
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
