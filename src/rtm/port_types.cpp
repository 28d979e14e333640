// SPDX-License-Identifier: Apache-2.0
// Instantiates the ports for every timed type of RTM.idl and RTMData.idl, so that the library
// build alone proves each of them compiles.
#include "rtm/inport.h"
#include "rtm/outport.h"
#include "rtm/ring_types.h"

#include <array>
#include <cstring>
#include <stdexcept>

namespace rtm {

#define RTM_INSTANTIATE_PORTS(Type) \
  template class InPort<RTM::Type>; \
  template class OutPort<RTM::Type>;
RTM_INSTANTIATE_PORTS(TimedFloat6)
RTM_INSTANTIATE_PORTS(TimedFloat)
RTM_INSTANTIATE_PORTS(TimedDouble)
RTM_INSTANTIATE_PORTS(TimedLong)
RTM_INSTANTIATE_PORTS(TimedBoolean)
RTM_INSTANTIATE_PORTS(TimedFloat3)
RTM_INSTANTIATE_PORTS(TimedFloatSeq)
RTM_INSTANTIATE_PORTS(TimedDoubleSeq)
#undef RTM_INSTANTIATE_PORTS

namespace {

template <PortData T>
void datum_to_any(std::span<const std::byte> datum, CORBA::Any& out) {
  if (datum.size() != sizeof(T))
    throw std::length_error(std::string(DataTraits<T>::name) + ": a datum of " + std::to_string(datum.size()) +
                            " bytes, expected " + std::to_string(sizeof(T)));
  T value;
  std::memcpy(&value, datum.data(), sizeof(T));
  out <<= value;
}

template <PortData T>
RingDataType ring_data_type() {
  static_assert(std::is_trivially_copyable_v<T>);
  return {ring_type_id<T>(), sizeof(T), &DataTraits<T>::type_code, &datum_to_any<T>};
}

}  // namespace

const RingDataType* find_ring_data_type(CORBA::TypeCode_ptr type) {
  static const std::array<RingDataType, 6> types{
      ring_data_type<RTM::TimedFloat6>(), ring_data_type<RTM::TimedFloat>(),   ring_data_type<RTM::TimedDouble>(),
      ring_data_type<RTM::TimedLong>(),   ring_data_type<RTM::TimedBoolean>(), ring_data_type<RTM::TimedFloat3>()};
  if (CORBA::is_nil(type)) return nullptr;
  for (const RingDataType& t : types) {
    if (type->equivalent(t.type_code())) return &t;
  }
  return nullptr;
}

}  // namespace rtm
