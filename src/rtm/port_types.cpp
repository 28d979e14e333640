// SPDX-License-Identifier: Apache-2.0
// Instantiates the ports for every timed type of RTM.idl and RTMData.idl, so that the library
// build alone proves each of them compiles.
#include "rtm/inport.h"
#include "rtm/outport.h"

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

}  // namespace rtm
