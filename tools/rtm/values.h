// Values on the command line: an RTM datum (a CORBA::Any holding one of the timed types) as
// text, as JSON, and back from the words a user types after `rtm put`.
#pragma once

#include <omniORB4/CORBA.h>

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace rtm::cli {

// A datum the tool cannot read or build, with the reason ("RTM::TimedFloat6 takes 6 values,
// got 5").
class ValueError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// One datum as a line of text: "2026-11-22T14:50:01.123456789Z  1.000 2.000 ..."; units, when
// given (one per value, as the port describes its elements), follow each value. Types the tool does not know print as
// "<type name>" with no values.
std::string format_text(const CORBA::Any& value, const std::vector<std::string>& units = {});

// One datum as JSON: {"type": "RTM::TimedFloat6", "time": {"sec":..,"nsec":..},
// "values": [..]}.
nlohmann::json format_json(const CORBA::Any& value);

// Time stamp and values as doubles (empty values for an unknown type); time in ns since the
// epoch. Used by watch's table and CSV.
struct Sample {
  std::string type;
  long long time_ns = 0;
  std::vector<double> values;
};
Sample to_sample(const CORBA::Any& value);

// Builds a datum of the port's type from words ("1", "2.5", "true"), stamped with the current
// time. Throws ValueError when the type is unknown, the count is wrong or a word is not a
// number (naming the word).
CORBA::Any parse_value(CORBA::TypeCode_ptr type, const std::vector<std::string>& words);

}  // namespace rtm::cli
