// SPDX-License-Identifier: Apache-2.0
#include "rtm/cdr.h"

#include <fmt/format.h>
#include <omniORB4/cdrStream.h>

#include <algorithm>
#include <bit>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string_view>

#include "rtm/data.h"

namespace rtm {

namespace {

// The encapsulation header: representation identifier CDR_LE (00 01) or CDR_BE (00 00), then two
// bytes of options.
constexpr std::uint8_t kCdrLittleEndian[4] = {0x00, 0x01, 0x00, 0x00};

// omniORB gives a stream its character code sets at ORB_init: without them a string or a char
// cannot be written (omniORB would dereference a null pointer).
void need_code_sets(const cdrMemoryStream& stream) {
  if (stream.TCS_C() == nullptr) throw std::logic_error("CDR needs the ORB: construct rtm::Orb first");
}

// The scoped name of a named type, and the modules it is in: IDL:RTM/Sub/Type:1.0 -> {RTM, Sub}, Type.
struct ScopedName {
  std::vector<std::string> modules;
  std::string name;
};

ScopedName scoped_name(CORBA::TypeCode_ptr tc) {
  ScopedName out;
  const std::string qualified = type_name(tc);  // "RTM::Sub::Type"
  std::string_view rest = qualified;
  for (auto sep = rest.find("::"); sep != std::string_view::npos; sep = rest.find("::")) {
    out.modules.emplace_back(rest.substr(0, sep));
    rest.remove_prefix(sep + 2);
  }
  out.name = rest;
  return out;
}

class IdlWriter {
 public:
  explicit IdlWriter(CORBA::TypeCode_ptr root) : root_(type_name(root)) {}

  // Writes the definition of every named type `tc` needs, then its own.
  void define(CORBA::TypeCode_ptr tc, const std::string& path) {
    switch (tc->kind()) {
      case CORBA::tk_struct: {
        const auto name = type_name(tc);
        if (defined(name)) return;
        for (CORBA::ULong i = 0; i < tc->member_count(); ++i) {
          CORBA::TypeCode_var member = tc->member_type(i);
          define(member, fmt::format("{}.{}", path, tc->member_name(i)));
        }
        std::string body;
        for (CORBA::ULong i = 0; i < tc->member_count(); ++i) {
          CORBA::TypeCode_var member = tc->member_type(i);
          body += fmt::format("    {};\n", declarator(member, tc->member_name(i), fmt::format("{}.{}", path, tc->member_name(i))));
        }
        emit(tc, fmt::format("struct {} {{\n{}  }};", scoped_name(tc).name, body));
        return;
      }
      case CORBA::tk_enum: {
        const auto name = type_name(tc);
        if (defined(name)) return;
        std::string members;
        for (CORBA::ULong i = 0; i < tc->member_count(); ++i) {
          members += fmt::format("{}{}", i ? ", " : "", tc->member_name(i));
        }
        emit(tc, fmt::format("enum {} {{ {} }};", scoped_name(tc).name, members));
        return;
      }
      case CORBA::tk_alias: {
        const auto name = type_name(tc);
        if (defined(name)) return;
        CORBA::TypeCode_var content = tc->content_type();
        define(content, path);
        emit(tc, fmt::format("typedef {};", declarator(content, scoped_name(tc).name, path)));
        return;
      }
      case CORBA::tk_sequence:
      case CORBA::tk_array: {
        CORBA::TypeCode_var content = tc->content_type();
        define(content, path);
        return;
      }
      default: return;  // basic types and strings need no definition
    }
  }

  std::string text() {
    close_modules(0);
    return out_;
  }

 private:
  bool defined(const std::string& name) {
    if (std::find(done_.begin(), done_.end(), name) != done_.end()) return true;
    done_.push_back(name);
    return false;
  }

  // `name` declared with type `tc`: "float v", "RTM::Time tm", "float val[6]", "sequence<double> v".
  std::string declarator(CORBA::TypeCode_ptr tc, std::string_view name, const std::string& path) {
    if (tc->kind() == CORBA::tk_array) {
      std::string dims;
      CORBA::TypeCode_var t = CORBA::TypeCode::_duplicate(tc);
      while (t->kind() == CORBA::tk_array) {
        dims += fmt::format("[{}]", t->length());
        t = t->content_type();
      }
      return fmt::format("{} {}{}", type_spec(t, path), name, dims);
    }
    return fmt::format("{} {}", type_spec(tc, path), name);
  }

  std::string type_spec(CORBA::TypeCode_ptr tc, const std::string& path) {
    switch (tc->kind()) {
      case CORBA::tk_short: return "short";
      case CORBA::tk_long: return "long";
      case CORBA::tk_ushort: return "unsigned short";
      case CORBA::tk_ulong: return "unsigned long";
      case CORBA::tk_longlong: return "long long";
      case CORBA::tk_ulonglong: return "unsigned long long";
      case CORBA::tk_float: return "float";
      case CORBA::tk_double: return "double";
      case CORBA::tk_boolean: return "boolean";
      case CORBA::tk_char: return "char";
      case CORBA::tk_octet: return "octet";
      case CORBA::tk_string: return tc->length() ? fmt::format("string<{}>", tc->length()) : "string";
      case CORBA::tk_struct:
      case CORBA::tk_enum:
      case CORBA::tk_alias: return type_name(tc);
      case CORBA::tk_sequence: {
        CORBA::TypeCode_var content = tc->content_type();
        auto element = content;
        while (element->kind() == CORBA::tk_alias) element = element->content_type();
        if (element->kind() == CORBA::tk_sequence || element->kind() == CORBA::tk_array) {
          unsupported(path, "a sequence of sequences or of arrays");
        }
        const auto of = type_spec(content, path);
        return tc->length() ? fmt::format("sequence<{}, {}>", of, tc->length()) : fmt::format("sequence<{}>", of);
      }
      case CORBA::tk_array: unsupported(path, "an anonymous array outside a member");
      case CORBA::tk_wchar: unsupported(path, "wchar");
      case CORBA::tk_wstring: unsupported(path, "wstring");
      case CORBA::tk_longdouble: unsupported(path, "long double");
      case CORBA::tk_any: unsupported(path, "any");
      case CORBA::tk_union: unsupported(path, "a union");
      case CORBA::tk_fixed: unsupported(path, "fixed");
      default: unsupported(path, fmt::format("a type of kind {}", static_cast<int>(tc->kind())));
    }
  }

  [[noreturn]] void unsupported(const std::string& path, const std::string& what) {
    throw std::invalid_argument(fmt::format(
        "{} cannot be written as omgidl: {} holds {}, which MCAP's omgidl readers do not decode", root_, path, what));
  }

  // A definition inside its modules: the modules still open are kept when the next is in them.
  void emit(CORBA::TypeCode_ptr tc, const std::string& definition) {
    const auto scoped = scoped_name(tc);
    std::size_t common = 0;
    while (common < open_.size() && common < scoped.modules.size() && open_[common] == scoped.modules[common]) {
      ++common;
    }
    close_modules(common);
    for (std::size_t i = common; i < scoped.modules.size(); ++i) {
      out_ += fmt::format("{}module {} {{\n", std::string(2 * i, ' '), scoped.modules[i]);
      open_.push_back(scoped.modules[i]);
    }
    out_ += fmt::format("{}{}\n", std::string(2 * open_.size(), ' '), definition);
  }

  void close_modules(std::size_t keep) {
    while (open_.size() > keep) {
      open_.pop_back();
      out_ += fmt::format("{}}};\n", std::string(2 * open_.size(), ' '));
    }
  }

  std::string root_;
  std::string out_;
  std::vector<std::string> open_;  // the modules open at the end of out_
  std::vector<std::string> done_;  // the types defined so far
};

}  // namespace

std::string idl_text(CORBA::TypeCode_ptr tc) {
  if (CORBA::is_nil(tc)) throw std::invalid_argument("no type to write as IDL (a nil TypeCode)");
  IdlWriter writer(tc);
  writer.define(tc, type_name(tc));
  return writer.text();
}

void to_cdr(const CORBA::Any& value, std::vector<std::uint8_t>& out) {
  cdrMemoryStream stream(0, true);  // padding zeroed: the same value gives the same bytes, and no stale memory leaves
  need_code_sets(stream);
  value.NP_marshalDataOnly(stream);
  const auto n = stream.bufSize();
  out.resize(sizeof kCdrLittleEndian + n);
  std::memcpy(out.data(), kCdrLittleEndian, sizeof kCdrLittleEndian);
  std::memcpy(out.data() + sizeof kCdrLittleEndian, stream.bufPtr(), n);
}

std::vector<std::uint8_t> to_cdr(const CORBA::Any& value) {
  std::vector<std::uint8_t> out;
  to_cdr(value, out);
  return out;
}

CORBA::Any from_cdr(CORBA::TypeCode_ptr tc, std::span<const std::uint8_t> bytes) {
  if (bytes.size() < 4 || bytes[0] != 0 || bytes[1] > 1) {
    throw std::invalid_argument(fmt::format("not encapsulated CDR for {}: the header is not 00 00 or 00 01", type_name(tc)));
  }
  // The stream aligns from its buffer's start: the body goes to an 8-byte aligned copy.
  const auto body = bytes.subspan(4);
  std::vector<std::uint64_t> aligned((body.size() + 7) / 8);
  std::memcpy(aligned.data(), body.data(), body.size());
  cdrMemoryStream stream(aligned.data(), body.size());
  need_code_sets(stream);
  stream.setByteSwapFlag(bytes[1] == 1);
  CORBA::Any value(tc, nullptr);
  try {
    value.NP_unmarshalDataOnly(stream);
  } catch (const CORBA::SystemException& e) {
    throw std::invalid_argument(fmt::format("{} bytes of CDR are not a whole {} ({})", body.size(), type_name(tc), e._name()));
  }
  // Up to 3 bytes of padding may close a value (some writers pad it to 4 bytes); more is not it.
  if (stream.checkInputOverrun(1, 4)) {
    throw std::invalid_argument(fmt::format("{} bytes of CDR hold a {} and bytes after it", body.size(), type_name(tc)));
  }
  return value;
}

std::string type_code_text(CORBA::TypeCode_ptr tc) {
  cdrMemoryStream stream(0, true);  // padding zeroed: the same value gives the same bytes, and no stale memory leaves
  need_code_sets(stream);
  CORBA::TypeCode::marshalTypeCode(tc, stream);
  const auto* p = static_cast<const std::uint8_t*>(stream.bufPtr());
  std::string hex;
  hex.reserve(2 * stream.bufSize());
  for (CORBA::ULong i = 0; i < stream.bufSize(); ++i) hex += fmt::format("{:02x}", p[i]);
  return hex;
}

CORBA::TypeCode_ptr type_code_from_text(const std::string& text) {
  // Far more than any data type's TypeCode: text beyond it is not one.
  constexpr std::size_t kMaxBytes = 64 * 1024;
  if (text.size() % 2 != 0 || text.size() / 2 > kMaxBytes) {
    throw std::invalid_argument("not a type code: its text is not an even number of hex digits up to 128 Ki");
  }
  std::vector<std::uint64_t> aligned((text.size() / 2 + 7) / 8);
  auto* bytes = reinterpret_cast<std::uint8_t*>(aligned.data());
  for (std::size_t i = 0; i < text.size() / 2; ++i) {
    unsigned value = 0;
    if (std::sscanf(text.c_str() + 2 * i, "%2x", &value) != 1) throw std::invalid_argument("not a type code: not hex");
    bytes[i] = static_cast<std::uint8_t>(value);
  }
  cdrMemoryStream stream(aligned.data(), text.size() / 2);
  need_code_sets(stream);
  stream.setByteSwapFlag(std::endian::native == std::endian::little);
  try {
    return CORBA::TypeCode::unmarshalTypeCode(stream);
  } catch (const CORBA::SystemException& e) {
    throw std::invalid_argument(fmt::format("not a type code ({})", e._name()));
  }
}

}  // namespace rtm
