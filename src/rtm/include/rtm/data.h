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

// CLOCK_MONOTONIC in nanoseconds, the clock activities schedule on: rtm::monotonic_ns() of
// rt/clock.h.

// ================================ types ===============================

// DataTraits<T>: the TypeCode and IDL name of a type a port can carry.
// Specialised for RTM::TimedFloat6 (RTM.idl) and every Timed* of RTMData.idl.
template <class T>
struct DataTraits;

// A type a port can carry.
template <class T>
concept PortData = requires {
  { DataTraits<T>::type_code() } -> std::same_as<CORBA::TypeCode_ptr>;
  { DataTraits<T>::name } -> std::convertible_to<std::string_view>;
};

#define RTM_DATA_TRAITS(Type, FixedSize, Elements)                               \
  template <>                                                                     \
  struct DataTraits<RTM::Type> {                                                  \
    static CORBA::TypeCode_ptr type_code() { return RTM::_tc_##Type; }            \
    static constexpr std::string_view name = "RTM::" #Type;                       \
    /* true: copying one allocates nothing */                                     \
    static constexpr bool fixed_size = FixedSize;                                 \
    /* values in one datum (0: a sequence, any number) */                         \
    static constexpr std::size_t elements = Elements;                             \
  };
RTM_DATA_TRAITS(TimedFloat6, true, 6)
RTM_DATA_TRAITS(TimedFloat, true, 1)
RTM_DATA_TRAITS(TimedDouble, true, 1)
RTM_DATA_TRAITS(TimedLong, true, 1)
RTM_DATA_TRAITS(TimedBoolean, true, 1)
RTM_DATA_TRAITS(TimedFloat3, true, 3)
RTM_DATA_TRAITS(TimedFloatSeq, false, 0)
RTM_DATA_TRAITS(TimedDoubleSeq, false, 0)
#undef RTM_DATA_TRAITS

// A data type of a project's own IDL (stubs made by rtm_add_idl in CMake), at global scope
// after the stub header: RTM_DATA_TYPE(My, TimedPose, 7) makes rtm::InPort<My::TimedPose> and
// rtm::OutPort<My::TimedPose> work, with the type checked at connect and on every put like the
// built-in ones. Elements: the values in one datum, for the tools (0 for a sequence).
#define RTM_DATA_TYPE(Module, Type, Elements)                                          \
  template <>                                                                         \
  struct rtm::DataTraits<Module::Type> {                                              \
    static CORBA::TypeCode_ptr type_code() { return Module::_tc_##Type; }             \
    static constexpr std::string_view name = #Module "::" #Type;                      \
    static constexpr bool fixed_size = std::is_trivially_copyable_v<Module::Type>;    \
    static constexpr std::size_t elements = Elements;                                 \
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
