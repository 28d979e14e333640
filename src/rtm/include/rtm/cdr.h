// SPDX-License-Identifier: Apache-2.0
// A port's data as other tools read it: its type as OMG IDL text, each datum as CDR.
//
// Our data types are OMG IDL, so a recording (MCAP's "omgidl" schema encoding, "cdr" message
// encoding) carries its own types, user types included, and opens in Foxglove, Lichtblick or any
// reader of that encoding with names. The IDL is written from the port's TypeCode, so it needs
// no .idl file at run time. Encoding and decoding need the process's ORB (rtm::Orb): omniORB
// sets up character code sets when it starts; without it they throw std::logic_error.
#pragma once

#include <omniORB4/CORBA.h>

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace rtm {

// The IDL that defines `tc` and every named type it needs, each in its modules, dependencies
// first: e.g. for RTM::TimedFloat6
//   module RTM { struct Time { unsigned long sec; unsigned long nsec; }; ... };
// Throws std::invalid_argument naming the part of the type that has no omgidl reading (wide
// characters, long double, any, unions, object references, value types, fixed).
std::string idl_text(CORBA::TypeCode_ptr tc);

// `value` as encapsulated CDR: the 4-byte header 00 01 00 00 (plain CDR, little-endian), then
// the value with each primitive aligned to its size from the byte after the header.
std::vector<std::uint8_t> to_cdr(const CORBA::Any& value);
// The same, appended to `out` (which is cleared first): no allocation once `out` is large enough.
void to_cdr(const CORBA::Any& value, std::vector<std::uint8_t>& out);

// A datum of type `tc` from encapsulated CDR, as to_cdr() writes it (big-endian CDR is taken
// too). Throws std::invalid_argument if the bytes are not a whole value of that type.
CORBA::Any from_cdr(CORBA::TypeCode_ptr tc, std::span<const std::uint8_t> bytes);

// A TypeCode as text (hex of its CDR marshalling, as GIOP carries it), and back: a recording
// keeps it beside the IDL, so that any RTM tool decodes its data with no .idl file and no live
// port of that type. type_code_from_text() throws std::invalid_argument for text that is not one.
std::string type_code_text(CORBA::TypeCode_ptr tc);
CORBA::TypeCode_ptr type_code_from_text(const std::string& text);

}  // namespace rtm
