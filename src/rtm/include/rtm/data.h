// SPDX-License-Identifier: Apache-2.0
// Data helpers: timestamps, the timed data types a port can carry, and their TypeCodes.
#pragma once

#include "RTM.hh"
#include "RTMData.hh"
#include "rt/clock.h"

#include <cmath>
#include <concepts>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <type_traits>

namespace rtm {

// ================================ time ================================

// Wall-clock time (CLOCK_REALTIME) as RTM::Time: data stamps are compared across processes
// and machines, so they use the clock NTP keeps in step. Schedules use CLOCK_MONOTONIC.
RTM::Time now();

// Nanoseconds since the epoch of a stamp; and back.
std::int64_t to_ns(const RTM::Time& t);
RTM::Time from_ns(std::int64_t ns);

// CLOCK_MONOTONIC in nanoseconds, the clock activities schedule on: rtm::monotonic_ns() of rt/clock.h.

// ================================ types ===============================

// The built-in data types, listed here once and nowhere else (the ports, the tools, the
// scaffold all read this list): X(Type, shape, member, elements, element), RTM.idl's
// TimedFloat6 first, then RTMData.idl's. shape: the values after the stamp are an array
// `member[elements]`, one scalar `member`, or a sequence `member`; element: their C++ type.
#define RTM_BUILTIN_DATA_TYPES(X)                  \
  X(TimedFloat6, array, val, 6, float)             \
  X(TimedFloat, scalar, data, 1, float)            \
  X(TimedDouble, scalar, data, 1, double)          \
  X(TimedLong, scalar, data, 1, CORBA::Long)       \
  X(TimedBoolean, scalar, data, 1, CORBA::Boolean) \
  X(TimedFloat3, array, val, 3, float)             \
  X(TimedFloatSeq, sequence, data, 0, float)       \
  X(TimedDoubleSeq, sequence, data, 0, double)

enum class DataShape : std::uint8_t { scalar, array, sequence };

// DataTraits<T>: the TypeCode and IDL name of a type a port can carry. Specialised for each
// built-in type above (with its shape, member and element too) and by RTM_DATA_TYPE.
template <class T>
struct DataTraits;

// A type a port can carry. The ports put a datum into an Any and take it out only through
// insert() and extract(): omniidl declares a type's Any operators at global scope, where a
// template defined before the stub header would not see them, so the traits (written after
// it) carry them and the order of the #include lines does not matter.
template <class T>
concept PortData = requires(CORBA::Any& any, const CORBA::Any& in, const T& value, const T*& out) {
  { DataTraits<T>::type_code() } -> std::same_as<CORBA::TypeCode_ptr>;
  { DataTraits<T>::name } -> std::convertible_to<std::string_view>;
  DataTraits<T>::insert(any, value);
  { DataTraits<T>::extract(in, out) } -> std::same_as<bool>;
};

// A datum that carries the stamp of the sample it derives from (RTM::Time tm, as the paper's
// TimedFloat6 does): a component passes its input's stamp on to what it writes from it (the
// controller gives its command the sensor sample's), so the end of a chain knows how old its
// data are (ComponentServant::watch_chain, docs/timing.md).
template <class T>
concept Stamped = requires(const T& value) {
  { value.tm.sec } -> std::convertible_to<long long>;
  { value.tm.nsec } -> std::convertible_to<long long>;
};

#define RTM_DATA_TRAITS(Type, Shape, Member, Elements, ElementType)                  \
  template <>                                                                     \
  struct DataTraits<RTM::Type> {                                                  \
    static CORBA::TypeCode_ptr type_code() { return RTM::_tc_##Type; }            \
    static constexpr std::string_view name = "RTM::" #Type;                       \
    /* true: copying one allocates nothing */                                     \
    static constexpr bool fixed_size = DataShape::Shape != DataShape::sequence;   \
    /* values in one datum (0: a sequence, any number) */                         \
    static constexpr std::size_t elements = Elements;                             \
    static constexpr DataShape shape = DataShape::Shape;                          \
    static constexpr std::string_view member = #Member;                           \
    using Element = ElementType;                                                  \
    static constexpr std::string_view element = #ElementType;                     \
    static const auto& values(const RTM::Type& d) { return d.Member; }            \
    static auto& values(RTM::Type& d) { return d.Member; }                        \
    static void insert(CORBA::Any& a, const RTM::Type& d) { a <<= d; }           \
    static bool extract(const CORBA::Any& a, const RTM::Type*& d) { return a >>= d; } \
  };
RTM_BUILTIN_DATA_TYPES(RTM_DATA_TRAITS)
#undef RTM_DATA_TRAITS

// Calls f.template operator()<T>() for each built-in type T, in the order of the list.
template <class F>
void for_each_builtin_type(F&& f) {
#define RTM_VISIT_TYPE(Type, Shape, Member, Elements, ElementType) f.template operator()<RTM::Type>();
  RTM_BUILTIN_DATA_TYPES(RTM_VISIT_TYPE)
#undef RTM_VISIT_TYPE
}

// The numbers in one datum of a type: the numeric leaves of its members after a leading stamp
// `tm` (nested structs and arrays flattened; a boolean, an enum or a char is one, a string none),
// or 0 when it holds a sequence (any number). 0 for a nil TypeCode.
std::size_t count_values(CORBA::TypeCode_ptr tc);

// DataTraits<T>::elements of a type whose count is read from its TypeCode (RTM_DATA_TYPE
// without one).
inline constexpr std::size_t kCountedElements = static_cast<std::size_t>(-1);
constexpr std::size_t elements_given() { return kCountedElements; }
constexpr std::size_t elements_given(std::size_t n) { return n; }

// The values in one datum of T (0: a sequence, any number).
template <class T>
std::size_t data_elements() {
  if constexpr (DataTraits<T>::elements == kCountedElements) {
    static const std::size_t counted = count_values(DataTraits<T>::type_code());
    return counted;
  } else {
    return DataTraits<T>::elements;
  }
}

// A data type of a project's own IDL (stubs made by rtm_add_idl in CMake), at global scope
// after the stub header (rtm headers may come before it or after): RTM_DATA_TYPE(My, TimedPose)
// makes rtm::InPort<My::TimedPose> and rtm::OutPort<My::TimedPose> work, with the type checked
// at connect and on every put like the built-in ones. A third argument gives the values in one
// datum (0 for a sequence); without it they are counted from the type (count_values).
// rtm_add_idl(... TYPES My::TimedPose) writes these lines into a header of its own.
#define RTM_DATA_TYPE(Module, Type, ...)                                                \
  template <>                                                                           \
  struct rtm::DataTraits<Module::Type> {                                                \
    static CORBA::TypeCode_ptr type_code() { return Module::_tc_##Type; }               \
    static constexpr std::string_view name = #Module "::" #Type;                        \
    static constexpr bool fixed_size = std::is_trivially_copyable_v<Module::Type>;      \
    static constexpr std::size_t elements = rtm::elements_given(__VA_ARGS__);           \
    static void insert(CORBA::Any& a, const Module::Type& d) { a <<= d; }               \
    static bool extract(const CORBA::Any& a, const Module::Type*& d) { return a >>= d; } \
  }

// A readable name for any TypeCode: "RTM::TimedFloat6" for IDL:RTM/TimedFloat6:1.0, the
// IDL keyword for basic types ("long", "double", ...), "<nil>" for a nil TypeCode.
std::string type_name(CORBA::TypeCode_ptr tc);

// ================================ checks ==============================

// True when any value is NaN or infinite (a datum a controller must not act on).
bool has_non_finite(const RTM::TimedFloat6& d);
bool has_non_finite(const RTM::TimedFloat3& d);
bool has_non_finite(const RTM::TimedFloatSeq& d);
bool has_non_finite(const RTM::TimedDoubleSeq& d);

// ============================ error minor codes =======================

// Minor codes of the system exceptions RTM raises (vendor-neutral values; documented here
// because omniORB's system exceptions cannot carry a message).
inline constexpr CORBA::ULong kMinorWrongDataType = 0x52544d01;  // BAD_PARAM: put of wrong type
inline constexpr CORBA::ULong kMinorNoDataYet = 0x52544d02;  // BAD_INV_ORDER: get before first write
inline constexpr CORBA::ULong kMinorComponentError = 0x52544d03;  // BAD_INV_ORDER: on() in COMPONENT_ERROR
// The access screen's (host/access.h), raised before a request's arguments are read:
inline constexpr CORBA::ULong kAccessRefusedMinor = 0x52544d01;  // NO_PERMISSION: a change by another user
inline constexpr CORBA::ULong kCallerUnknownMinor = 0x52544d03;  // NO_PERMISSION: over plain TCP from elsewhere
inline constexpr CORBA::ULong kNotPlainDataMinor = 0x52544d02;   // BAD_PARAM: a put of no data type (an any of an any)
// What a refused change means, for the minor code of its NO_PERMISSION: the sentence `rtm`
// prints and an OutPort's refused subscribe keeps, naming this process's user.
std::string access_refusal_text(std::uint32_t minor);

}  // namespace rtm
