// SPDX-License-Identifier: Apache-2.0
// A datum's stamp in its CDR: for a timed type (browser/values.h's is_timed_type), the 8 bytes
// after the 4-byte encapsulation header (sec, nsec; little-endian, as rtm::to_cdr writes).
#pragma once

#include <cstdint>
#include <vector>

namespace rtm::cli {

// The stamp in ns; cdr is a datum of such a type.
std::uint64_t stamp_of(const std::vector<std::uint8_t>& cdr);
// Writes `ns` as the stamp of such a datum.
void restamp(std::vector<std::uint8_t>& cdr, std::uint64_t ns);

}  // namespace rtm::cli
