// SPDX-License-Identifier: Apache-2.0
#include "browser/values.h"

#include "rtm/data.h"
#include "rtm/orb.h"

#include <fmt/format.h>

#include <cctype>
#include <charconv>
#include <cstdint>
#include <cmath>
#include <ctime>
#include <limits>
#include <optional>
#include <type_traits>

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

// The values of a built-in datum after its stamp, as numbers.
template <rtm::PortData T>
std::vector<double> values_of(const T& d) {
  using Traits = rtm::DataTraits<T>;
  const auto& member = Traits::values(d);
  std::vector<double> v;
  if constexpr (Traits::shape == rtm::DataShape::scalar) {
    v.push_back(static_cast<double>(member));
  } else if constexpr (Traits::shape == rtm::DataShape::array) {
    v.assign(member, member + Traits::elements);
  } else {
    for (CORBA::ULong i = 0; i < member.length(); ++i) v.push_back(member[i]);
  }
  return v;
}

// Calls f(time, values, datum) for a built-in type (rtm/data.h's list); false for any other.
template <class F>
bool visit(const CORBA::Any& any, F&& f) {
  bool found = false;
  rtm::for_each_builtin_type([&]<class T>() {
    const T* d = nullptr;
    if (found || !(any >>= d)) return;
    found = true;
    f(d->tm, values_of(*d), *d);
  });
  return found;
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

// "fields" of a built-in type: its one member after tm, by name; a long as an integer, a
// boolean as true/false.
template <rtm::PortData T>
nlohmann::json builtin_fields(const T& d, const std::vector<double>& v) {
  using Traits = rtm::DataTraits<T>;
  nlohmann::json j = nlohmann::json::object();
  const std::string member(Traits::member);
  if constexpr (std::is_same_v<typename Traits::Element, CORBA::Boolean>) {
    j[member] = static_cast<bool>(Traits::values(d));
  } else if constexpr (std::is_same_v<typename Traits::Element, CORBA::Long>) {
    j[member] = Traits::values(d);
  } else if constexpr (Traits::shape == rtm::DataShape::scalar) {
    j[member] = v.at(0);
  } else {
    j[member] = v;
  }
  return j;
}

// ================= any other struct, walked with DynamicAny =================

CORBA::TypeCode_var unalias(CORBA::TypeCode_ptr type) {
  CORBA::TypeCode_var tc = CORBA::TypeCode::_duplicate(type);
  while (tc->kind() == CORBA::tk_alias) tc = tc->content_type();
  return tc;
}

// A struct whose first member is an RTM::Time named tm: a timed datum, stamped by it.
bool is_timed(CORBA::TypeCode_ptr struct_tc) {
  if (struct_tc->member_count() == 0 || std::string_view(struct_tc->member_name(0)) != "tm") return false;
  CORBA::TypeCode_var member = struct_tc->member_type(0);
  CORBA::TypeCode_var time = unalias(member);
  return time->equivalent(RTM::_tc_Time);
}

// Kinds that are one leaf: one value, one word.
bool is_leaf(CORBA::TCKind kind) {
  switch (kind) {
    case CORBA::tk_short: case CORBA::tk_ushort: case CORBA::tk_long: case CORBA::tk_ulong:
    case CORBA::tk_longlong: case CORBA::tk_ulonglong: case CORBA::tk_float: case CORBA::tk_double:
    case CORBA::tk_boolean: case CORBA::tk_octet: case CORBA::tk_char: case CORBA::tk_wchar:
    case CORBA::tk_enum: case CORBA::tk_string:
      return true;
    default:
      return false;
  }
}

std::string member_path(const std::string& path, const char* name) {
  return path.empty() ? std::string(name) : path + "." + name;
}

// The DynAnyFactory of the process's ORB (rtm::Orb's, or the one ORB_init returns).
DynamicAny::DynAnyFactory_var dyn_any_factory() {
  CORBA::ORB_var orb;
  if (const rtm::Orb* o = rtm::Orb::instance()) {
    orb = CORBA::ORB::_duplicate(o->orb());
  } else {
    int argc = 0;
    orb = CORBA::ORB_init(argc, nullptr);
  }
  CORBA::Object_var obj = orb->resolve_initial_references("DynAnyFactory");
  return DynamicAny::DynAnyFactory::_narrow(obj);
}

// A top-level DynAny, destroyed with its components when it goes out of scope.
class DynAnyHolder {
 public:
  explicit DynAnyHolder(DynamicAny::DynAny_ptr d) : d_(d) {}
  ~DynAnyHolder() {
    try {
      d_->destroy();
    } catch (const CORBA::Exception&) {
    }
  }
  DynAnyHolder(const DynAnyHolder&) = delete;
  DynAnyHolder& operator=(const DynAnyHolder&) = delete;
  DynamicAny::DynAny_ptr get() const { return d_.in(); }

 private:
  DynamicAny::DynAny_var d_;
};

DynamicAny::DynAny_var component(DynamicAny::DynAny_ptr d, CORBA::ULong i) {
  d->seek(static_cast<CORBA::Long>(i));
  return d->current_component();
}

// One leaf as read: its number (none for a string or a kind the tool cannot show), its text and
// its JSON.
struct Leaf {
  std::optional<double> number;
  std::string text;
  nlohmann::json json;
};

template <class T>
Leaf integer_leaf(T v) {
  return Leaf{static_cast<double>(v), fmt::format("{}", v), v};
}

Leaf read_leaf(DynamicAny::DynAny_ptr d, CORBA::TypeCode_ptr tc) {
  switch (tc->kind()) {
    case CORBA::tk_float: {
      const double x = d->get_float();
      return Leaf{x, fmt::format("{:.4f}", x), x};
    }
    case CORBA::tk_double: {
      const double x = d->get_double();
      return Leaf{x, fmt::format("{:.4f}", x), x};
    }
    case CORBA::tk_short: return integer_leaf(static_cast<int>(d->get_short()));
    case CORBA::tk_ushort: return integer_leaf(static_cast<unsigned>(d->get_ushort()));
    case CORBA::tk_long: return integer_leaf(static_cast<long long>(d->get_long()));
    case CORBA::tk_ulong: return integer_leaf(static_cast<unsigned long long>(d->get_ulong()));
    case CORBA::tk_longlong: return integer_leaf(static_cast<long long>(d->get_longlong()));
    case CORBA::tk_ulonglong: return integer_leaf(static_cast<unsigned long long>(d->get_ulonglong()));
    case CORBA::tk_octet: return integer_leaf(static_cast<unsigned>(d->get_octet()));
    case CORBA::tk_char: return integer_leaf(static_cast<unsigned>(static_cast<unsigned char>(d->get_char())));
    case CORBA::tk_wchar: return integer_leaf(static_cast<unsigned long>(d->get_wchar()));
    case CORBA::tk_boolean: {
      const bool b = d->get_boolean();
      return Leaf{b ? 1.0 : 0.0, b ? "true" : "false", b};
    }
    case CORBA::tk_enum: {
      DynamicAny::DynEnum_var e = DynamicAny::DynEnum::_narrow(d);
      CORBA::String_var label = e->get_as_string();
      return Leaf{static_cast<double>(e->get_as_ulong()), label.in(), label.in()};
    }
    case CORBA::tk_string: {
      CORBA::String_var s = d->get_string();
      return Leaf{std::nullopt, s.in(), s.in()};
    }
    default:
      return Leaf{std::nullopt, fmt::format("<{}>", rtm::type_name(tc)), nullptr};
  }
}

// Walks a datum: text parts ("p.x=0.0010"), numbers in order, and the JSON of each member.
// With names (one per number), each number is shown as name=value, lists of leaves too.
class Reader {
 public:
  Reader(const std::vector<std::string>& units, const std::vector<std::string>& names)
      : units_(units), names_(names) {}

  nlohmann::json read(DynamicAny::DynAny_ptr d, const std::string& path) {
    CORBA::TypeCode_var type = d->type();
    CORBA::TypeCode_var tc = unalias(type);
    const CORBA::TCKind kind = tc->kind();
    if (kind == CORBA::tk_struct) return read_struct(d, tc, path, 0);
    if (kind == CORBA::tk_array || kind == CORBA::tk_sequence) return read_list(d, tc, path);
    const Leaf leaf = read_leaf(d, tc);
    const std::string label = label_of(leaf, path);
    parts.push_back(fmt::format("{}={}", label, show(leaf, path)));
    return leaf.json;
  }

  // The members from `first` on (1 skips a time stamp).
  nlohmann::json read_struct(DynamicAny::DynAny_ptr d, CORBA::TypeCode_ptr tc, const std::string& path,
                             CORBA::ULong first) {
    nlohmann::json j = nlohmann::json::object();
    for (CORBA::ULong i = first; i < tc->member_count(); ++i) {
      DynamicAny::DynAny_var c = component(d, i);
      j[tc->member_name(i)] = read(c, member_path(path, tc->member_name(i)));
    }
    return j;
  }

  std::vector<std::string> parts;
  std::vector<double> numbers;
  std::vector<std::string> number_paths;  // the leaf path of each number: "p.x", "q[2]"

 private:
  // The next number's name when names are given, else the leaf's path.
  std::string label_of(const Leaf& leaf, const std::string& path) const {
    return leaf.number && numbers.size() < names_.size() ? names_[numbers.size()] : path;
  }

  // An array or sequence: of leaves as one part "q=[1.0000 0.0000]", else element by element.
  nlohmann::json read_list(DynamicAny::DynAny_ptr d, CORBA::TypeCode_ptr tc, const std::string& path) {
    nlohmann::json j = nlohmann::json::array();
    CORBA::TypeCode_var content = tc->content_type();
    CORBA::TypeCode_var element = unalias(content);
    const bool of_leaves = is_leaf(element->kind());
    std::string line;
    const CORBA::ULong n = d->component_count();
    for (CORBA::ULong i = 0; i < n; ++i) {
      DynamicAny::DynAny_var c = component(d, i);
      if (of_leaves && !names_.empty()) {
        j.push_back(read(c, fmt::format("{}[{}]", path, i)));  // each number by its name
      } else if (of_leaves) {
        const Leaf leaf = read_leaf(c, element);
        if (i != 0) line += ' ';
        line += show(leaf, fmt::format("{}[{}]", path, i));
        j.push_back(leaf.json);
      } else {
        j.push_back(read(c, fmt::format("{}[{}]", path, i)));
      }
    }
    if (of_leaves && names_.empty()) parts.push_back(fmt::format("{}=[{}]", path, line));
    return j;
  }

  // The leaf's text with its unit; a number is counted as the next value.
  std::string show(const Leaf& leaf, const std::string& path) {
    if (!leaf.number) return leaf.text;
    std::string s = leaf.text;
    const std::size_t i = numbers.size();
    if (i < units_.size() && !units_[i].empty()) s += " " + units_[i];
    numbers.push_back(*leaf.number);
    number_paths.push_back(path);
    return s;
  }

  const std::vector<std::string>& units_;
  const std::vector<std::string>& names_;
};

// A struct datum of any type as read.
struct Walked {
  std::optional<RTM::Time> time;
  std::vector<std::string> parts;
  std::vector<double> numbers;
  std::vector<std::string> number_paths;
  nlohmann::json fields;
};

// Reads any struct; nothing for other types, or when the ORB cannot walk the value.
std::optional<Walked> walk(const CORBA::Any& value, const std::vector<std::string>& units = {},
                           const std::vector<std::string>& names = {}) {
  CORBA::TypeCode_var type = value.type();
  CORBA::TypeCode_var tc = unalias(type);
  if (tc->kind() != CORBA::tk_struct) return std::nullopt;
  try {
    DynamicAny::DynAnyFactory_var factory = dyn_any_factory();
    DynAnyHolder d(factory->create_dyn_any(value));
    Walked w;
    CORBA::ULong first = 0;
    if (is_timed(tc)) {
      DynamicAny::DynAny_var c = component(d.get(), 0);
      CORBA::Any_var stamp = c->to_any();
      const RTM::Time* t = nullptr;
      if (stamp.in() >>= t) w.time = *t;
      first = 1;
    }
    Reader reader(units, names);
    w.fields = reader.read_struct(d.get(), tc, "", first);
    w.parts = std::move(reader.parts);
    w.numbers = std::move(reader.numbers);
    w.number_paths = std::move(reader.number_paths);
    return w;
  } catch (const CORBA::Exception&) {
    return std::nullopt;
  }
}

// ---------------------------- from words ----------------------------

// The words a struct takes, in order: its leaves, and the one sequence that takes the rest.
struct Layout {
  std::vector<std::string> paths;  // leaves outside the sequence
  std::string sequence;            // the sequence's path; empty when there is none
  std::size_t per_element = 0;     // words per element of it
  CORBA::ULong bound = 0;          // its bound; 0: unbounded
};

void lay_out(CORBA::TypeCode_ptr type, const std::string& path, Layout& out) {
  CORBA::TypeCode_var tc = unalias(type);
  const CORBA::TCKind kind = tc->kind();
  if (!out.sequence.empty()) {
    throw ValueError(fmt::format("{} is followed by {}: rtm put fills a sequence only when it comes last",
                                 out.sequence, path));
  }
  if (kind == CORBA::tk_struct) {
    for (CORBA::ULong i = 0; i < tc->member_count(); ++i) {
      CORBA::TypeCode_var member = tc->member_type(i);
      lay_out(member, member_path(path, tc->member_name(i)), out);
    }
  } else if (kind == CORBA::tk_array) {
    CORBA::TypeCode_var element = tc->content_type();
    for (CORBA::ULong i = 0; i < tc->length(); ++i) lay_out(element, fmt::format("{}[{}]", path, i), out);
  } else if (kind == CORBA::tk_sequence) {
    Layout element;
    CORBA::TypeCode_var content = tc->content_type();
    lay_out(content, path + "[i]", element);
    if (!element.sequence.empty() || element.paths.empty()) {
      throw ValueError(fmt::format("{}: rtm put cannot fill a sequence of sequences", path));
    }
    out.sequence = path;
    out.per_element = element.paths.size();
    out.bound = tc->length();
  } else if (is_leaf(kind)) {
    out.paths.push_back(path);
  } else {
    throw ValueError(fmt::format("{}: rtm put cannot type a value of {}", path, rtm::type_name(tc)));
  }
}

// The member paths a type takes, for a message: "p.x p.y p.z", at most 12 of them.
std::string list_paths(const std::vector<std::string>& paths) {
  std::string out;
  for (std::size_t i = 0; i < paths.size() && i < 12; ++i) {
    if (i != 0) out += ' ';
    out += paths[i];
  }
  if (paths.size() > 12) out += " ...";
  return out;
}

// Checks the word count against the layout; returns the length of the sequence.
CORBA::ULong sequence_length(const std::string& type, const Layout& layout, std::size_t words) {
  const std::size_t fixed = layout.paths.size();
  const std::string takes = fmt::format("{} takes {} value{}{}", type, fixed, fixed == 1 ? "" : "s",
                                        fixed == 0 ? "" : " (" + list_paths(layout.paths) + ")");
  if (layout.sequence.empty()) {
    if (words != fixed) throw ValueError(fmt::format("{}, got {}", takes, words));
    return 0;
  }
  const std::string rest = layout.per_element == 1
                               ? fmt::format("then any number for {}", layout.sequence)
                               : fmt::format("then {} per element of {}", layout.per_element, layout.sequence);
  if (words < fixed || (words - fixed) % layout.per_element != 0) {
    throw ValueError(fmt::format("{} and {}, got {}", takes, rest, words));
  }
  const std::size_t n = (words - fixed) / layout.per_element;
  if (layout.bound != 0 && n > layout.bound) {
    throw ValueError(fmt::format("{} holds at most {} elements, got {}", layout.sequence, layout.bound, n));
  }
  return static_cast<CORBA::ULong>(n);
}

// ---- one word as one leaf; messages name the member and the word ----

double word_to_double(const std::string& path, const std::string& word) {
  double x = 0;
  const char* end = word.data() + word.size();
  auto [ptr, ec] = std::from_chars(word.data(), end, x);
  if (ec == std::errc::result_out_of_range && ptr == end) {
    throw ValueError(fmt::format("{}: '{}' is out of the range of double", path, word));
  }
  if (ec != std::errc() || ptr != end) throw ValueError(fmt::format("{}: '{}' is not a number", path, word));
  if (!std::isfinite(x)) throw ValueError(fmt::format("{}: '{}' is not a finite number", path, word));
  return x;
}

float word_to_float(const std::string& path, const std::string& word) {
  const double x = word_to_double(path, word);
  if (std::abs(x) > static_cast<double>(std::numeric_limits<float>::max())) {
    throw ValueError(fmt::format("{}: '{}' is out of the range of float (|x| <= 3.4e38)", path, word));
  }
  return static_cast<float>(x);
}

// A whole number of type T: digits ("-42"), or a number that is whole ("1e3", "2.0").
template <class T>
T word_to_integer(const std::string& path, const std::string& word, std::string_view type) {
  const auto out_of_range = [&] {
    return ValueError(fmt::format("{}: '{}' is out of the range of {} ({} to {})", path, word, type,
                                  +std::numeric_limits<T>::min(), +std::numeric_limits<T>::max()));
  };
  T x{};
  const char* end = word.data() + word.size();
  auto [ptr, ec] = std::from_chars(word.data(), end, x);
  if (ec == std::errc() && ptr == end) return x;
  if (ec == std::errc::result_out_of_range && ptr == end) throw out_of_range();
  const double d = word_to_double(path, word);
  if (d != std::trunc(d)) throw ValueError(fmt::format("{}: '{}' is not a whole number", path, word));
  const double limit = std::ldexp(1.0, std::numeric_limits<T>::digits);
  if (d >= limit || d < (std::is_signed_v<T> ? -limit : 0.0)) throw out_of_range();
  return static_cast<T>(d);
}

bool word_to_boolean(const std::string& path, const std::string& word) {
  if (word == "true" || word == "1") return true;
  if (word == "false" || word == "0") return false;
  throw ValueError(fmt::format("{}: '{}' is not a boolean (true, false, 1 or 0)", path, word));
}

// An enum by label ("RUN") or index ("1").
CORBA::ULong word_to_enum(const std::string& path, const std::string& word, CORBA::TypeCode_ptr tc) {
  const CORBA::ULong count = tc->member_count();
  std::string labels;
  for (CORBA::ULong i = 0; i < count; ++i) {
    if (word == tc->member_name(i)) return i;
    if (i != 0) labels += ", ";
    labels += tc->member_name(i);
  }
  CORBA::ULong index = 0;
  const char* end = word.data() + word.size();
  auto [ptr, ec] = std::from_chars(word.data(), end, index);
  if (ec == std::errc() && ptr == end && index < count) return index;
  throw ValueError(fmt::format("{}: '{}' is not one of {} (or their index, 0 to {})", path, word, labels, count - 1));
}

// A char by its code ("65") or as itself ("A").
CORBA::Char word_to_char(const std::string& path, const std::string& word) {
  if (word.size() == 1 && !std::isdigit(static_cast<unsigned char>(word[0]))) return word[0];
  return static_cast<CORBA::Char>(word_to_integer<unsigned char>(path, word, "char"));
}

void fill_leaf(DynamicAny::DynAny_ptr d, CORBA::TypeCode_ptr tc, const std::string& path, const std::string& word) {
  switch (tc->kind()) {
    case CORBA::tk_float: d->insert_float(word_to_float(path, word)); return;
    case CORBA::tk_double: d->insert_double(word_to_double(path, word)); return;
    case CORBA::tk_short: d->insert_short(word_to_integer<CORBA::Short>(path, word, "short")); return;
    case CORBA::tk_ushort: d->insert_ushort(word_to_integer<CORBA::UShort>(path, word, "unsigned short")); return;
    case CORBA::tk_long: d->insert_long(word_to_integer<CORBA::Long>(path, word, "long")); return;
    case CORBA::tk_ulong: d->insert_ulong(word_to_integer<CORBA::ULong>(path, word, "unsigned long")); return;
    case CORBA::tk_longlong: d->insert_longlong(word_to_integer<CORBA::LongLong>(path, word, "long long")); return;
    case CORBA::tk_ulonglong:
      d->insert_ulonglong(word_to_integer<CORBA::ULongLong>(path, word, "unsigned long long"));
      return;
    case CORBA::tk_octet: d->insert_octet(word_to_integer<CORBA::Octet>(path, word, "octet")); return;
    case CORBA::tk_char: d->insert_char(word_to_char(path, word)); return;
    case CORBA::tk_wchar: d->insert_wchar(word_to_integer<std::uint16_t>(path, word, "wchar")); return;
    case CORBA::tk_boolean: d->insert_boolean(word_to_boolean(path, word)); return;
    case CORBA::tk_enum: {
      DynamicAny::DynEnum_var e = DynamicAny::DynEnum::_narrow(d);  // released: the DynAny can go
      e->set_as_ulong(word_to_enum(path, word, tc));
      return;
    }
    case CORBA::tk_string:
      if (tc->length() != 0 && word.size() > tc->length()) {
        throw ValueError(fmt::format("{}: '{}' is longer than the {} characters it holds", path, word, tc->length()));
      }
      d->insert_string(word.c_str());
      return;
    default:
      throw ValueError(fmt::format("{}: rtm put cannot type a value of {}", path, rtm::type_name(tc)));
  }
}

// Fills a datum's leaves from words, in order; the one sequence gets sequence_length elements.
class Writer {
 public:
  Writer(const std::vector<std::string>& words, CORBA::ULong sequence_length)
      : words_(words), sequence_length_(sequence_length) {}

  void fill_struct(DynamicAny::DynAny_ptr d, CORBA::TypeCode_ptr tc, const std::string& path, CORBA::ULong first) {
    for (CORBA::ULong i = first; i < tc->member_count(); ++i) {
      DynamicAny::DynAny_var c = component(d, i);
      fill(c, member_path(path, tc->member_name(i)));
    }
  }

 private:
  void fill(DynamicAny::DynAny_ptr d, const std::string& path) {
    CORBA::TypeCode_var type = d->type();
    CORBA::TypeCode_var tc = unalias(type);
    const CORBA::TCKind kind = tc->kind();
    if (kind == CORBA::tk_struct) {
      fill_struct(d, tc, path, 0);
      return;
    }
    if (kind == CORBA::tk_sequence) {
      DynamicAny::DynSequence_var sequence = DynamicAny::DynSequence::_narrow(d);
      sequence->set_length(sequence_length_);
    }
    if (kind == CORBA::tk_array || kind == CORBA::tk_sequence) {
      const CORBA::ULong n = d->component_count();
      for (CORBA::ULong i = 0; i < n; ++i) {
        DynamicAny::DynAny_var c = component(d, i);
        fill(c, fmt::format("{}[{}]", path, i));
      }
      return;
    }
    fill_leaf(d, tc, path, words_.at(next_++));
  }

  const std::vector<std::string>& words_;
  const CORBA::ULong sequence_length_;
  std::size_t next_ = 0;
};

// Any struct type from words: the leaves in order, a leading tm stamped now.
CORBA::Any parse_struct(CORBA::TypeCode_ptr type, CORBA::TypeCode_ptr tc, const std::vector<std::string>& words) {
  const std::string name = rtm::type_name(type);
  const CORBA::ULong first = is_timed(tc) ? 1 : 0;
  Layout layout;
  for (CORBA::ULong i = first; i < tc->member_count(); ++i) {
    CORBA::TypeCode_var member = tc->member_type(i);
    lay_out(member, tc->member_name(i), layout);
  }
  const CORBA::ULong length = sequence_length(name, layout, words.size());
  try {
    DynamicAny::DynAnyFactory_var factory = dyn_any_factory();
    DynAnyHolder d(factory->create_dyn_any_from_type_code(type));
    if (first == 1) {
      DynamicAny::DynAny_var stamp = component(d.get(), 0);
      CORBA::Any now;
      now <<= rtm::now();
      stamp->from_any(now);
    }
    Writer(words, length).fill_struct(d.get(), tc, "", first);
    CORBA::Any_var out = d.get()->to_any();
    return out.in();
  } catch (const CORBA::Exception& e) {
    throw ValueError(fmt::format("rtm cannot build a value of type {} ({})", name, e._name()));
  }
}

}  // namespace

std::string format_text(const CORBA::Any& value, const std::vector<std::string>& units,
                        const std::vector<std::string>& names) {
  std::string line;
  bool known = visit(value, [&](const RTM::Time& tm, const std::vector<double>& v, const auto&) {
    line = format_time(tm);
    for (std::size_t i = 0; i < v.size(); ++i) {
      line += fmt::format("  {:.4f}", v[i]);
      if (i < units.size() && !units[i].empty()) line += " " + units[i];
    }
  });
  if (known) return line;
  // Named only when there is a name for every number (the port describes every element).
  static const std::vector<std::string> kUnnamed;
  CORBA::TypeCode_var type = value.type();
  const bool named = !names.empty() && names.size() == rtm::count_values(type);
  if (auto w = walk(value, units, named ? names : kUnnamed)) {
    if (w->time) line = format_time(*w->time);
    for (const auto& part : w->parts) {
      if (!line.empty()) line += "  ";
      line += part;
    }
    return line;
  }
  return fmt::format("<{}>", rtm::type_name(type));
}

nlohmann::json format_json(const CORBA::Any& value) {
  CORBA::TypeCode_var tc = value.type();
  nlohmann::json j{{"type", rtm::type_name(tc)}};
  auto stamp = [&](const RTM::Time& tm) {
    j["time"] = {{"sec", static_cast<unsigned long>(tm.sec)},
                 {"nsec", static_cast<unsigned long>(tm.nsec)}};
  };
  const bool known = visit(value, [&](const RTM::Time& tm, const std::vector<double>& v, const auto& datum) {
    stamp(tm);
    j["values"] = v;
    j["fields"] = builtin_fields(datum, v);
  });
  if (known) return j;
  if (auto w = walk(value)) {
    if (w->time) stamp(*w->time);
    j["values"] = w->numbers;
    j["fields"] = std::move(w->fields);
  }
  return j;
}

std::vector<std::string> value_labels(const CORBA::Any& value, const std::vector<std::string>& names) {
  std::vector<std::string> labels;
  const bool known = visit(value, [&](const RTM::Time&, const std::vector<double>& v, const auto&) {
    for (std::size_t i = 0; i < v.size(); ++i) labels.push_back(fmt::format("v{}", i));
  });
  if (!known) {
    if (auto w = walk(value)) labels = std::move(w->number_paths);
  }
  if (!names.empty() && names.size() == labels.size()) return names;
  return labels;
}

Sample to_sample(const CORBA::Any& value) {
  CORBA::TypeCode_var tc = value.type();
  Sample s{rtm::type_name(tc), 0, {}};
  const bool known = visit(value, [&](const RTM::Time& tm, const std::vector<double>& v, const auto&) {
    s.time_ns = rtm::to_ns(tm);
    s.values = v;
  });
  if (known) return s;
  if (auto w = walk(value)) {
    if (w->time) s.time_ns = rtm::to_ns(*w->time);
    s.values = std::move(w->numbers);
  }
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
  // One element of a built-in type from a number, refused when the type cannot hold it.
  auto element = [&]<class E>(double x, const std::string& word) -> E {
    if constexpr (std::is_same_v<E, CORBA::Boolean>) {
      return x != 0.0;
    } else if constexpr (std::is_same_v<E, CORBA::Long>) {
      x = narrow(x);
      if (x != std::trunc(x) || x < -2147483648.0 || x > 2147483647.0)
        throw ValueError(fmt::format("{} takes a whole number in the long range, got {}", name, word));
      return static_cast<CORBA::Long>(x);
    } else if constexpr (std::is_same_v<E, float>) {
      return to_float(x);
    } else {
      return narrow(x);
    }
  };
  bool built = false;
  rtm::for_each_builtin_type([&]<class T>() {
    using Traits = rtm::DataTraits<T>;
    using E = typename Traits::Element;
    if (built || !type->equivalent(Traits::type_code())) return;
    const std::vector<double> v = parse_numbers(words, Traits::elements, name);
    T d;
    d.tm = rtm::now();
    auto& member = Traits::values(d);
    if constexpr (Traits::shape == rtm::DataShape::scalar) {
      member = element.template operator()<E>(v[0], words[0]);
    } else if constexpr (Traits::shape == rtm::DataShape::array) {
      for (std::size_t i = 0; i < Traits::elements; ++i) member[i] = element.template operator()<E>(v[i], words[i]);
    } else {
      member.length(static_cast<CORBA::ULong>(v.size()));
      for (CORBA::ULong i = 0; i < v.size(); ++i) member[i] = element.template operator()<E>(v[i], words[i]);
    }
    any <<= d;
    built = true;
  });
  if (!built) {
    CORBA::TypeCode_var tc = unalias(type);
    if (tc->kind() != CORBA::tk_struct) throw ValueError(fmt::format("rtm cannot build a value of type {}", name));
    return parse_struct(type, tc, words);
  }
  return any;
}

bool is_timed_type(CORBA::TypeCode_ptr type) {
  CORBA::TypeCode_var tc = unalias(type);
  return tc->kind() == CORBA::tk_struct && is_timed(tc);
}

}  // namespace rtm::cli
