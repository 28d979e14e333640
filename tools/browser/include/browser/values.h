// SPDX-License-Identifier: Apache-2.0
// Values on the command line: an RTM datum (a CORBA::Any holding a struct a port carries) as
// text, as JSON, and back from the words a user types after `rtm put`.
//
// The built-in timed types (RTM::TimedFloat6, TimedFloat3, TimedFloat, TimedDouble, TimedLong,
// TimedBoolean, TimedFloatSeq, TimedDoubleSeq) are read and built directly. Any other struct is
// walked through its TypeCode with DynamicAny, so the tool needs no stubs of a project's own IDL:
//
// - A struct whose first member is an RTM::Time named `tm` is a timed datum; that member is its
//   stamp. Other structs have no stamp.
// - Its leaves are the basic members of the other members, in declaration order, with nested
//   structs, arrays and sequences flattened. A leaf's path names it in output and messages:
//   "p.x", "q[2]", "points[1].y".
// - The numbers ("values") are the numeric leaves: float, double, the integers (short, long,
//   long long and the unsigned ones, octet; char as its code), boolean as 0/1 and an enum as
//   its index. A string is a leaf but no number. Other kinds (any, unions, object references,
//   wstring, ...) show as "<type name>" and cannot be put.
//
// The functions that walk a value use the DynAnyFactory of the process's ORB (rtm::Orb's).
#pragma once

#include <omniORB4/CORBA.h>

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace rtm::cli {

// A datum the tool cannot read or build, with the reason ("RTM::TimedFloat6 takes 6 values,
// got 5", "p.y: 'abc' is not a number").
class ValueError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One datum as a line of text; units, when given (one per value, as the port describes its
// elements), follow each number.
// - A built-in type: the UTC stamp, then the values:
//     "2026-11-22T14:50:01.123456789Z  1.0000 N  2.0000 N ..."
// - Any other struct: the stamp (when timed), then "path=value" per leaf, two spaces apart; an
//   array or sequence of leaves as one "path=[v v v]". Floats and doubles show 4 decimals,
//   integers as they are, booleans as true/false, enums by label, strings as themselves:
//     "2026-11-22T14:50:01.123456789Z  p.x=0.0010  p.y=0.5000  p.z=0.0000  q=[1.0000 0.0000 0.0000 0.0000]"
//     "2026-11-22T14:50:01.123456789Z  n=-7  on=true  mode=RUN  data=[0.5000 1.5000]"
// - Any other type: "<type name>" with no values.
// A value is labelled by the port's element names when there is one for each of its numbers
// (names, as the port describes its elements), else by its leaf path: a struct of another type
// then shows "x=0.0010 m  y=0.5000 m  ...  qw=1.0000" (arrays of leaves number by number).
// value_labels() gives the same labels to the CSV columns of `rtm watch`.
std::string format_text(const CORBA::Any& value, const std::vector<std::string>& units = {},
                        const std::vector<std::string>& names = {});

// The label of each number of a datum, in order: names when there is one per number; else the
// leaf paths of a struct of another type ("p.x", "q[0]"), "v0", "v1", ... for a built-in one.
std::vector<std::string> value_labels(const CORBA::Any& value, const std::vector<std::string>& names = {});

// One datum as JSON:
//   {"type": "RtmTest::TimedPose", "time": {"sec": 1795445401, "nsec": 123456789},
//    "values": [0.001, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0],
//    "fields": {"p": {"x": 0.001, "y": 0.5, "z": 0.0}, "q": [1.0, 0.0, 0.0, 0.0]}}
// "values": the numbers, flattened (as to_sample); "fields": the members after the stamp by
// name, nested as in the struct (booleans as true/false, enums and strings as strings, kinds
// the tool cannot show as null). No "time" for a struct without a stamp; only "type" for a
// type that is no struct. Built-in types have the same keys ("fields": {"val": [...]} or
// {"data": ...}).
nlohmann::json format_json(const CORBA::Any& value);

// Time stamp and numbers as doubles (empty values for a type that is no struct, strings
// skipped); time in ns since the epoch, 0 without a stamp. Used by watch's table and CSV.
struct Sample {
  std::string type;
  long long time_ns = 0;
  std::vector<double> values;
};
Sample to_sample(const CORBA::Any& value);
// Whether a datum of this type (aliases followed) is stamped: a struct whose first member is an
// RTM::Time named tm.
bool is_timed_type(CORBA::TypeCode_ptr type);

// Builds a datum of the port's type from words, one per leaf in order, stamped with the current
// time (a `tm` stamp is never taken from the words). Numbers are range-checked for their member's
// type (a float takes |x| <= 3.4e38, a long -2147483648 to 2147483647, ...; no NaN or infinity);
// booleans take true/false/1/0, enums a label or an index, a char a code or one character, a
// string one word. One sequence may take the rest of the words, whole elements of it, when no
// leaf follows it. Throws ValueError when the type is no struct, the count is wrong or a word
// does not fit (naming the member path and the word).
CORBA::Any parse_value(CORBA::TypeCode_ptr type, const std::vector<std::string>& words);

}  // namespace rtm::cli
