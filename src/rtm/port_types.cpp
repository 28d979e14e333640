// SPDX-License-Identifier: Apache-2.0
// Instantiates the ports for every timed type of RTM.idl and RTMData.idl, so that the library
// build alone proves each of them compiles.
#include "rtm/inport.h"
#include "rtm/outport.h"
#include "rtm/ring_types.h"

#include <cstring>
#include <stdexcept>
#include <vector>

namespace rtm {

#define RTM_INSTANTIATE_PORTS(Type, Shape, Member, Elements, ElementType) \
  template class InPort<RTM::Type>;                                  \
  template class OutPort<RTM::Type>;
RTM_BUILTIN_DATA_TYPES(RTM_INSTANTIATE_PORTS)
#undef RTM_INSTANTIATE_PORTS

namespace {

template <PortData T>
void datum_to_any(std::span<const std::byte> datum, CORBA::Any& out) {
  if (datum.size() != sizeof(T))
    throw std::length_error(std::string(DataTraits<T>::name) + ": a datum of " + std::to_string(datum.size()) +
                            " bytes, expected " + std::to_string(sizeof(T)));
  T value;
  std::memcpy(&value, datum.data(), sizeof(T));
  DataTraits<T>::insert(out, value);
}

template <PortData T>
RingDataType ring_data_type() {
  static_assert(std::is_trivially_copyable_v<T>);
  return {ring_type_id<T>(), sizeof(T), &DataTraits<T>::type_code, &datum_to_any<T>};
}

}  // namespace

const RingDataType* find_ring_data_type(CORBA::TypeCode_ptr type) {
  // Every built-in type of plain memory (no sequence).
  static const std::vector<RingDataType> types = [] {
    std::vector<RingDataType> plain;
    for_each_builtin_type([&]<class T>() {
      if constexpr (DataTraits<T>::fixed_size) plain.push_back(ring_data_type<T>());
    });
    return plain;
  }();
  if (CORBA::is_nil(type)) return nullptr;
  for (const RingDataType& t : types) {
    if (type->equivalent(t.type_code())) return &t;
  }
  return nullptr;
}

}  // namespace rtm
