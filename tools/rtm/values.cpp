#include "values.h"

#include "rtm/data.h"

#include <fmt/format.h>

#include <charconv>
#include <cmath>
#include <ctime>
#include <limits>

namespace rtm::cli {
namespace {

std::string format_time(const RTM::Time& t) {
  std::time_t seconds = static_cast<std::time_t>(t.sec);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%S", &utc);
  return fmt::format("{}.{:09}Z", date, static_cast<unsigned long>(t.nsec));
}

// Calls f(time, values) for each known type; returns false for an unknown one.
template <class F>
bool visit(const CORBA::Any& any, F&& f) {
  const RTM::TimedFloat6* f6 = nullptr;
  const RTM::TimedFloat3* f3 = nullptr;
  const RTM::TimedFloat* f1 = nullptr;
  const RTM::TimedDouble* d1 = nullptr;
  const RTM::TimedLong* l1 = nullptr;
  const RTM::TimedBoolean* b1 = nullptr;
  const RTM::TimedFloatSeq* fs = nullptr;
  const RTM::TimedDoubleSeq* ds = nullptr;
  std::vector<double> v;
  if (any >>= f6) {
    v.assign(f6->val, f6->val + 6);
    f(f6->tm, v);
  } else if (any >>= f3) {
    v.assign(f3->val, f3->val + 3);
    f(f3->tm, v);
  } else if (any >>= f1) {
    f(f1->tm, std::vector<double>{f1->data});
  } else if (any >>= d1) {
    f(d1->tm, std::vector<double>{d1->data});
  } else if (any >>= l1) {
    f(l1->tm, std::vector<double>{static_cast<double>(l1->data)});
  } else if (any >>= b1) {
    f(b1->tm, std::vector<double>{b1->data ? 1.0 : 0.0});
  } else if (any >>= fs) {
    for (CORBA::ULong i = 0; i < fs->data.length(); ++i) v.push_back(fs->data[i]);
    f(fs->tm, v);
  } else if (any >>= ds) {
    for (CORBA::ULong i = 0; i < ds->data.length(); ++i) v.push_back(ds->data[i]);
    f(ds->tm, v);
  } else {
    return false;
  }
  return true;
}

double parse_number(const std::string& word) {
  if (word == "true") return 1.0;
  if (word == "false") return 0.0;
  double x = 0;
  const char* end = word.data() + word.size();
  auto [ptr, ec] = std::from_chars(word.data(), end, x);
  if (ec != std::errc() || ptr != end) throw ValueError(fmt::format("'{}' is not a number", word));
  return x;
}

std::vector<double> parse_numbers(const std::vector<std::string>& words, std::size_t expected,
                                  std::string_view type) {
  if (expected != 0 && words.size() != expected) {
    throw ValueError(fmt::format("{} takes {} value{}, got {}", type, expected,
                                 expected == 1 ? "" : "s", words.size()));
  }
  std::vector<double> out;
  out.reserve(words.size());
  for (const auto& w : words) out.push_back(parse_number(w));
  return out;
}

}  // namespace

std::string format_text(const CORBA::Any& value, const std::vector<std::string>& units) {
  std::string line;
  bool known = visit(value, [&](const RTM::Time& tm, const std::vector<double>& v) {
    line = format_time(tm);
    for (std::size_t i = 0; i < v.size(); ++i) {
      line += fmt::format("  {:.4f}", v[i]);
      if (i < units.size() && !units[i].empty()) line += " " + units[i];
    }
  });
  if (!known) {
    CORBA::TypeCode_var tc = value.type();
    line = fmt::format("<{}>", rtm::type_name(tc));
  }
  return line;
}

nlohmann::json format_json(const CORBA::Any& value) {
  CORBA::TypeCode_var tc = value.type();
  nlohmann::json j{{"type", rtm::type_name(tc)}};
  visit(value, [&](const RTM::Time& tm, const std::vector<double>& v) {
    j["time"] = {{"sec", static_cast<unsigned long>(tm.sec)},
                 {"nsec", static_cast<unsigned long>(tm.nsec)}};
    j["values"] = v;
  });
  return j;
}

Sample to_sample(const CORBA::Any& value) {
  CORBA::TypeCode_var tc = value.type();
  Sample s{rtm::type_name(tc), 0, {}};
  visit(value, [&](const RTM::Time& tm, const std::vector<double>& v) {
    s.time_ns = rtm::to_ns(tm);
    s.values = v;
  });
  return s;
}

CORBA::Any parse_value(CORBA::TypeCode_ptr type, const std::vector<std::string>& words) {
  const std::string name = rtm::type_name(type);
  CORBA::Any any;
  auto narrow = [&](double x) {
    if (!std::isfinite(x)) throw ValueError(fmt::format("{} is not a finite value", x));
    return x;
  };
  // A value a float cannot hold would be sent as inf.
  auto to_float = [&](double x) {
    if (std::abs(narrow(x)) > static_cast<double>(std::numeric_limits<float>::max()))
      throw ValueError(fmt::format("{} is out of the range of {}'s float elements (|x| <= 3.4e38)", x, name));
    return static_cast<float>(x);
  };
  if (type->equivalent(RTM::_tc_TimedFloat6)) {
    auto v = parse_numbers(words, 6, name);
    RTM::TimedFloat6 d;
    d.tm = rtm::now();
    for (int i = 0; i < 6; ++i) d.val[i] = to_float(v[i]);
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedFloat3)) {
    auto v = parse_numbers(words, 3, name);
    RTM::TimedFloat3 d;
    d.tm = rtm::now();
    for (int i = 0; i < 3; ++i) d.val[i] = to_float(v[i]);
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedFloat)) {
    RTM::TimedFloat d{rtm::now(), to_float(parse_numbers(words, 1, name)[0])};
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedDouble)) {
    RTM::TimedDouble d{rtm::now(), narrow(parse_numbers(words, 1, name)[0])};
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedLong)) {
    double x = narrow(parse_numbers(words, 1, name)[0]);
    if (x != std::trunc(x) || x < -2147483648.0 || x > 2147483647.0) {
      throw ValueError(fmt::format("{} takes a whole number in the long range, got {}", name, words[0]));
    }
    RTM::TimedLong d{rtm::now(), static_cast<CORBA::Long>(x)};
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedBoolean)) {
    RTM::TimedBoolean d{rtm::now(), parse_numbers(words, 1, name)[0] != 0.0};
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedFloatSeq)) {
    auto v = parse_numbers(words, 0, name);
    RTM::TimedFloatSeq d;
    d.tm = rtm::now();
    d.data.length(static_cast<CORBA::ULong>(v.size()));
    for (CORBA::ULong i = 0; i < v.size(); ++i) d.data[i] = to_float(v[i]);
    any <<= d;
  } else if (type->equivalent(RTM::_tc_TimedDoubleSeq)) {
    auto v = parse_numbers(words, 0, name);
    RTM::TimedDoubleSeq d;
    d.tm = rtm::now();
    d.data.length(static_cast<CORBA::ULong>(v.size()));
    for (CORBA::ULong i = 0; i < v.size(); ++i) d.data[i] = narrow(v[i]);
    any <<= d;
  } else {
    throw ValueError(fmt::format("rtm cannot build a value of type {}", name));
  }
  return any;
}

}  // namespace rtm::cli
