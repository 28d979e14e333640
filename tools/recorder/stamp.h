// SPDX-License-Identifier: Apache-2.0
// A datum's stamp in its CDR: for a type whose first member is `RTM::Time tm`, the 8 bytes
// after the 4-byte encapsulation header (sec, nsec; little-endian, as rtm::to_cdr writes).
#pragma once

#include <cstdint>
#include <vector>

#include <omniORB4/CORBA.h>

namespace rtm::cli {

// True when a datum of this type starts with its stamp (`RTM::Time tm`).
bool starts_with_stamp(CORBA::TypeCode_ptr tc);
// The stamp in ns; cdr is a datum of such a type.
std::uint64_t stamp_of(const std::vector<std::uint8_t>& cdr);
// Writes `ns` as the stamp of such a datum.
void restamp(std::vector<std::uint8_t>& cdr, std::uint64_t ns);

}  // namespace rtm::cli
