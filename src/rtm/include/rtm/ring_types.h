// SPDX-License-Identifier: Apache-2.0
// The built-in data types of plain memory as a shared-memory ring (rt/shm_ring.h) carries
// them, for readers that learn a port's type only at run time (`rtm watch`, the demo's
// recorders): a ring's type id names the type, its TypeCode and how one datum becomes an any.
//
//   const RingDataType* t = find_ring_data_type(port_type_code);   // nullptr: CORBA only
//   if (t && t->type_id == offered_type_id) ... t->to_any(bytes, any) ...
//
// A project's own IDL types and the sequences are not listed: their readers keep CORBA.
#pragma once

#include <omniORB4/CORBA.h>

#include <cstddef>
#include <cstdint>
#include <span>

namespace rtm {

struct RingDataType {
  std::uint64_t type_id;               // ring_type_id<T>() (rtm/inport.h)
  std::size_t size;                    // sizeof(T), bytes of one datum in the ring
  CORBA::TypeCode_ptr (*type_code)();  // DataTraits<T>::type_code (not duplicated)
  // Copies one datum (size bytes, any alignment) into out. Throws std::length_error when
  // datum holds another number of bytes.
  void (*to_any)(std::span<const std::byte> datum, CORBA::Any& out);
};

// The built-in plain type whose TypeCode is equivalent to type, or nullptr.
const RingDataType* find_ring_data_type(CORBA::TypeCode_ptr type);

}  // namespace rtm
