// SPDX-License-Identifier: Apache-2.0
// A client of 2004: it knows only the paper's RTM.idl and the CORBA naming service. It finds
// an RTM component, lists its ports, subscribes an InPort servant of its own and receives
// TimedFloat6 data, as the paper's component browser did. It carries no credential of any
// kind (host/access.h): run by the component's own user on its host, its changes are taken as
// that user's; another user's only by a component started with --access open, as the
// fixture's is.
#include <RTM.hh>
#include <omniORB4/CORBA.h>
#include <omniORB4/Naming.hh>

#include <gtest/gtest.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "rtm_test/child_process.h"
#include "rtm_test/eventually.h"
#include "rtm_test/omni_names.h"

namespace {

using namespace std::chrono_literals;
using rtm_test::eventually;

// The client's own InPort, written against the seed skeleton only.
class SeedInPort : public POA_RTM::InPort {
 public:
  void put(const CORBA::Any& value) override {
    const RTM::TimedFloat6* datum = nullptr;
    if (!(value >>= datum)) throw CORBA::BAD_PARAM();
    // A slow subscriber, once: the first put takes this long before it keeps its datum.
    if (const int ms = first_put_ms.exchange(0); ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(ms));
    std::lock_guard lock(mutex_);
    received_.push_back(*datum);
  }
  std::atomic<int> first_put_ms{0};
  char* name() override { return CORBA::string_dup("seed_client.in"); }
  CORBA::TypeCode_ptr port_type() override { return CORBA::TypeCode::_duplicate(RTM::_tc_TimedFloat6); }

  std::vector<RTM::TimedFloat6> received() const {
    std::lock_guard lock(mutex_);
    return received_;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<RTM::TimedFloat6> received_;
};

std::string host_name() {
  std::array<char, 256> buffer{};
  ::gethostname(buffer.data(), buffer.size() - 1);
  return buffer.data();
}

class SeedClient : public ::testing::Test {
 protected:
  void SetUp() override {
    int argc = 3;
    const char* argv[] = {"seed_client", "-ORBendPoint", "giop:tcp:127.0.0.1:", nullptr};
    orb_ = CORBA::ORB_init(argc, const_cast<char**>(argv));
    CORBA::Object_var poa_object = orb_->resolve_initial_references("RootPOA");
    poa_ = PortableServer::POA::_narrow(poa_object);
    PortableServer::POAManager_var manager = poa_->the_POAManager();
    manager->activate();

    component_process_ = std::make_unique<rtm_test::ChildProcess>(std::vector<std::string>{
        RTM_TEST_COMPONENT, "--name", "seedpeer0", "--naming", names_.address(), "--period",
        "2ms", "--on", "--access", "open"});
    component_process_->wait_until_bound();
  }

  void TearDown() override {
    component_process_.reset();
    orb_->destroy();
  }

  // As a 2004 client does it: the naming service by corbaloc, then the name path.
  RTM::RtComponent_var find_component(const std::string& name) {
    const std::string corbaloc = "corbaloc::" + names_.address() + "/NameService";
    CORBA::Object_var root_object = orb_->string_to_object(corbaloc.c_str());
    CosNaming::NamingContext_var root = CosNaming::NamingContext::_narrow(root_object);
    CosNaming::Name path;
    path.length(2);
    path[0].id = CORBA::string_dup(host_name().c_str());
    path[0].kind = CORBA::string_dup("host_cxt");
    path[1].id = CORBA::string_dup(name.c_str());
    path[1].kind = CORBA::string_dup("rtc");
    CORBA::Object_var object = root->resolve(path);
    return RTM::RtComponent::_narrow(object);
  }

  RTM::OutPort_var first_out_port(RTM::RtComponent_ptr component) {
    RTM::OutPortList_var outs = component->out_ports();
    if (outs->length() == 0) return RTM::OutPort::_nil();
    return RTM::OutPort::_duplicate(outs[0]);
  }

  rtm_test::OmniNames names_;
  CORBA::ORB_var orb_;
  PortableServer::POA_var poa_;
  std::unique_ptr<rtm_test::ChildProcess> component_process_;
};

// A put that left before the unsubscribe (write()'s own call that timed out, say) can still be
// in the POA when the test deactivates the servant: it lives on the heap, reference counted, and
// the POA lets it go after its last upcall, not the test's scope.
PortableServer::Servant_var<SeedInPort> make_seed_in_port() { return new SeedInPort; }

std::vector<RTM::TimedFloat6> wait_for_data(const SeedInPort& port, std::size_t count) {
  eventually([&] { return port.received().size() >= count; });
  return port.received();
}

// val[0] of the latest datum `out` holds (the test component's ramp: the cycle that wrote it).
float latest_ramp(RTM::OutPort_ptr out) {
  CORBA::Any_var value = out->get();
  const RTM::TimedFloat6* datum = nullptr;
  return (value.in() >>= datum) ? datum->val[0] : -1.0f;
}

// As the paper's browser did: activates `servant`, subscribes it (repeated) to `out`, waits
// for `count` data, then unsubscribes and deactivates it. What it received.
std::vector<RTM::TimedFloat6> receive_stream(PortableServer::POA_ptr poa, RTM::OutPort_ptr out, SeedInPort* servant,
                                             std::size_t count) {
  PortableServer::ObjectId_var id = poa->activate_object(servant);
  CORBA::Object_var object = poa->id_to_reference(id);
  RTM::InPort_var in = RTM::InPort::_narrow(object);
  std::vector<RTM::TimedFloat6> data;
  if (out->subscribe(RTM::repeated, in)) {
    data = wait_for_data(*servant, count);
    EXPECT_TRUE(out->unsubscribe(RTM::repeated, in));
  } else {
    ADD_FAILURE() << "subscribe refused";
  }
  poa->deactivate_object(id);
  return data;
}

TEST_F(SeedClient, FindsComponentInNamingServiceAndListsItsPorts) {
  auto component = find_component("seedpeer0");
  ASSERT_FALSE(CORBA::is_nil(component));

  RTM::OutPortList_var outs = component->out_ports();
  RTM::InPortList_var ins = component->in_ports();
  ASSERT_GE(outs->length(), 1u);
  ASSERT_GE(ins->length(), 1u);
  CORBA::String_var out_name = outs[0]->name();
  CORBA::TypeCode_var out_type = outs[0]->port_type();
  EXPECT_STRNE(out_name.in(), "");
  EXPECT_TRUE(out_type->equivalent(RTM::_tc_TimedFloat6));
  CORBA::TypeCode_var in_type = ins[0]->port_type();
  EXPECT_TRUE(in_type->equivalent(RTM::_tc_TimedFloat6));
}

TEST_F(SeedClient, SubscribedSeedInPortReceivesRisingTimedFloat6Stream) {
  auto component = find_component("seedpeer0");
  auto out = first_out_port(component);
  ASSERT_FALSE(CORBA::is_nil(out));

  auto servant = make_seed_in_port();
  const auto data = receive_stream(poa_, out, servant.in(), 20);
  ASSERT_GE(data.size(), 20u);
  // The test component writes a ramp: val[0] grows by one per cycle; stamps never go back.
  for (std::size_t i = 1; i < data.size(); ++i) {
    EXPECT_GT(data[i].val[0], data[i - 1].val[0]) << "datum " << i;
    const auto stamp = [](const RTM::Time& t) { return std::uint64_t{t.sec} * 1'000'000'000u + t.nsec; };
    EXPECT_GE(stamp(data[i].tm), stamp(data[i - 1].tm)) << "datum " << i;
  }
}

// A 2004 client has no way to put data in order (no InPortOrdered): a call to it that timed
// out but still arrived after the next datum would be kept as the newer. Its first put here
// takes 30 ms, far over the 2 ms bound on a write()'s own call: the data still come in order.
TEST_F(SeedClient, ASlowPutIsNotOvertakenByTheDataAfterIt) {
  auto out = first_out_port(find_component("seedpeer0"));
  ASSERT_FALSE(CORBA::is_nil(out));
  auto servant = make_seed_in_port();
  servant->first_put_ms = 30;
  const auto data = receive_stream(poa_, out, servant.in(), 20);
  ASSERT_GE(data.size(), 20u);
  EXPECT_EQ(servant->first_put_ms.load(), 0) << "the slow put was made";
  for (std::size_t i = 1; i < data.size(); ++i)
    EXPECT_GT(data[i].val[0], data[i - 1].val[0]) << "datum " << i << " came after a newer one";
}

TEST_F(SeedClient, OnceSubscriptionDeliversExactlyOneDatum) {
  auto out = first_out_port(find_component("seedpeer0"));
  auto servant = make_seed_in_port();
  PortableServer::ObjectId_var id = poa_->activate_object(servant.in());
  CORBA::Object_var object = poa_->id_to_reference(id);
  RTM::InPort_var in = RTM::InPort::_narrow(object);

  ASSERT_TRUE(out->subscribe(RTM::once, in));
  const auto first = wait_for_data(*servant, 1);
  // Many periods later there is still exactly one: the component wrote 100 data after it.
  ASSERT_FALSE(first.empty());
  ASSERT_TRUE(eventually([&] { return latest_ramp(out) >= first.front().val[0] + 100.0f; })) << "the component kept running";
  poa_->deactivate_object(id);
  EXPECT_EQ(servant->received().size(), 1u);
}

TEST_F(SeedClient, GetReturnsTimedFloat6InAny) {
  auto out = first_out_port(find_component("seedpeer0"));
  // The component is on: wait for its first write.
  CORBA::Any_var value;
  ASSERT_TRUE(eventually([&] {
    try {
      value = out->get();
      return true;
    } catch (const CORBA::BAD_INV_ORDER&) {
      return false;
    }
  })) << "no datum written";
  const RTM::TimedFloat6* datum = nullptr;
  ASSERT_TRUE(value.in() >>= datum);
  EXPECT_GE(datum->val[0], 0.0f);
}

// Not opened to all, the component still takes the changes of its own user's 2004 client: the
// kernel, not a key, says who calls (another user's are refused: RtmCli.RunAsTheUserNobody...).
TEST_F(SeedClient, RunByTheComponentsOwnUserItsChangesAreTakenWithoutAnyKeyByAComponentNotOpened) {
  rtm_test::ChildProcess owned({RTM_TEST_COMPONENT, "--name", "owned0", "--naming", names_.address(), "--on"});
  owned.wait_until_bound();
  auto component = find_component("owned0");
  RTM::OutPortList_var outs = component->out_ports();
  ASSERT_GT(outs->length(), 0u);
  auto servant = make_seed_in_port();
  PortableServer::ObjectId_var id = poa_->activate_object(servant.in());
  CORBA::Object_var object = poa_->id_to_reference(id);
  RTM::InPort_var in = RTM::InPort::_narrow(object);
  EXPECT_TRUE(outs[0]->subscribe(RTM::repeated, in));
  eventually([&] { return !servant->received().empty(); });
  EXPECT_FALSE(servant->received().empty()) << "no datum reached the 2004 client's InPort";
  EXPECT_TRUE(outs[0]->unsubscribe(RTM::repeated, in));
  EXPECT_NO_THROW(component->off());
  RTM::InPortList_var ins = component->in_ports();
  ASSERT_GT(ins->length(), 0u);
  CORBA::Any datum;
  datum <<= RTM::TimedFloat6{};
  EXPECT_NO_THROW(ins[0]->put(datum));
  poa_->deactivate_object(id);
}

}  // namespace
