// SPDX-License-Identifier: Apache-2.0
// The user-space bus: delivery to every other endpoint and never back to the sender, robustness
// against dying endpoints and malformed datagrams, filters, and the bus-spec errors.
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <atomic>
#include <chrono>
#include <pthread.h>
#include <sched.h>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <thread>
#include <vector>

#include "arm/can/bus.h"
#include "arm/can/local_bus.h"
#include "arm/can/receive_thread.h"
#include "rt/thread.h"
#include "rtm_test/eventually.h"
#include "rtm_test/can/test_paths.h"

namespace rtm::can {
namespace {

using namespace std::chrono_literals;
using ::testing::HasSubstr;
using testing::TempDir;

// Generous: only a lower bound on patience, never an assertion about speed.
constexpr std::int64_t kArrives_ns = 5'000'000'000;
// How long to wait for a frame that must NOT come; the test cannot fail by being slow.
constexpr std::int64_t kAbsent_ns = 100'000'000;

can_frame frame(canid_t id, std::uint8_t first_byte) {
  can_frame f{};
  f.can_id = id;
  f.can_dlc = 1;
  f.data[0] = first_byte;
  return f;
}

using rtm_test::eventually;

TEST(CanLocalBus, DeliversToEveryOtherEndpointAndNotBackToTheSender) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto a = open_bus("local:" + dir.file("bus"));
  auto b = open_bus("local:" + dir.file("bus"));
  auto c = open_bus("local:" + dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 3; }));

  ASSERT_TRUE(a->send(frame(0x123, 42)));
  can_frame got{};
  ASSERT_TRUE(b->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x123u);
  EXPECT_EQ(got.data[0], 42);
  ASSERT_TRUE(c->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x123u);
  EXPECT_FALSE(a->receive(got, kAbsent_ns));
  EXPECT_EQ(a->name(), "local:" + dir.file("bus"));
}

TEST(CanLocalBus, KeepsTheOrderOfOneSendersFrames) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  auto b = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 2; }));
  for (int i = 0; i < 100; ++i) ASSERT_TRUE(a->send(frame(0x100, static_cast<std::uint8_t>(i))));
  can_frame got{};
  for (int i = 0; i < 100; ++i) {
    ASSERT_TRUE(b->receive(got, kArrives_ns));
    EXPECT_EQ(got.data[0], i);
  }
}

// A hub with three endpoints connected to it.
struct ThreeEndpoints {
  TempDir dir;
  LocalHub hub{dir.file("bus")};
  std::unique_ptr<Bus> a = open_local(dir.file("bus"));
  std::unique_ptr<Bus> b = open_local(dir.file("bus"));
  std::unique_ptr<Bus> c = open_local(dir.file("bus"));
  bool connected() { return eventually([&] { return hub.endpoint_count() == 3; }); }
};

// The lock-step primitive: once fence() returns, every frame sent before it is in the other
// endpoints' queues (receive with no wait finds it), and the frames that came for the fencing
// endpoint meanwhile are still there for it.
TEST(CanLocalBus, AfterAFenceEveryFrameSentBeforeItIsQueuedAtEveryOtherEndpoint) {
  ThreeEndpoints bus;
  ASSERT_TRUE(bus.connected());
  auto& [dir, hub, a, b, c] = bus;
  ASSERT_TRUE(c->send(frame(0x300, 7)));  // for a, while it fences
  constexpr int kFrames = 200;            // a datagram each: several rounds of the hub
  for (int i = 0; i < kFrames; ++i) ASSERT_TRUE(a->send(frame(0x100, static_cast<std::uint8_t>(i))));
  ASSERT_TRUE(a->fence(kArrives_ns));
  // The hub publishes its counters after the round that answered.
  EXPECT_TRUE(eventually([&] { return hub.counters().fences_answered == 1u; }));
  can_frame got{};
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_TRUE(b->receive(got, 0)) << "frame " << i << " is not queued at b after the fence";
    if (got.can_id == 0x300) {  // c's, in between
      ASSERT_TRUE(b->receive(got, 0));
    }
    EXPECT_EQ(got.data[0], i);
  }
  ASSERT_TRUE(a->receive(got, kArrives_ns)) << "c's frame, which came while a fenced, is kept";
  EXPECT_EQ(got.can_id, 0x300u);
  EXPECT_EQ(got.data[0], 7);
}

TEST(CanLocalBus, ABatchArrivesWholeAndInOrderAcrossSeveralSystemCalls) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  auto b = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 2; }));
  // 40 frames: more than one datagram (kMaxFramesPerDatagram, 32).
  std::vector<can_frame> batch;
  for (int i = 0; i < 40; ++i) batch.push_back(frame(static_cast<canid_t>(0x200 + i), static_cast<std::uint8_t>(i)));
  EXPECT_EQ(a->send_batch(batch), batch.size());
  EXPECT_EQ(a->send_batch({}), 0u);
  can_frame got{};
  for (int i = 0; i < 40; ++i) {
    ASSERT_TRUE(b->receive(got, kArrives_ns)) << "frame " << i;
    EXPECT_EQ(got.can_id, static_cast<canid_t>(0x200 + i));
    EXPECT_EQ(got.data[0], i);
  }
  EXPECT_FALSE(b->receive(got, kAbsent_ns)) << "a frame sent twice";
  EXPECT_FALSE(a->receive(got, kAbsent_ns)) << "the sender heard its own batch";
}

sockaddr_un unix_address(const std::string& path) {
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
  return address;
}

// A raw peer of the bus protocol: connects to a hub at `path` and writes or reads whatever it
// likes (-1 when it cannot).
int connect_raw(const std::string& path) {
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
  const sockaddr_un address = unix_address(path);
  if (fd >= 0 && ::connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address) == 0) return fd;
  if (fd >= 0) ::close(fd);
  return -1;
}

// A hub that is a raw peer of the protocol: one endpoint of ours connected to it, and the
// peer's end of that connection, to write or read whatever it likes.
struct RawHub {
  explicit RawHub(const std::string& path) {
    listener = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
    const sockaddr_un address = unix_address(path);
    if (listener < 0 || ::bind(listener, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
        ::listen(listener, 1) != 0)
      throw std::runtime_error("cannot listen at " + path);
    endpoint = open_local(path);
    peer = ::accept(listener, nullptr, nullptr);
  }
  ~RawHub() {
    if (peer >= 0) ::close(peer);
    ::close(listener);
  }
  RawHub(const RawHub&) = delete;
  RawHub& operator=(const RawHub&) = delete;
  int listener = -1;
  std::unique_ptr<Bus> endpoint;
  int peer = -1;
};

// The frames of one datagram `fd` receives within kArrives_ns (none: an empty vector).
std::vector<can_frame> receive_datagram(int fd) {
  pollfd p{fd, POLLIN, 0};
  std::vector<can_frame> frames(kMaxFramesPerDatagram + 1);
  if (::poll(&p, 1, static_cast<int>(kArrives_ns / 1'000'000)) != 1) return {};
  const ssize_t n = ::recv(fd, frames.data(), frames.size() * sizeof(can_frame), 0);
  frames.resize(n > 0 ? static_cast<std::size_t>(n) / sizeof(can_frame) : 0);
  return frames;
}

// A cycle's batch is one datagram each way: the endpoint sends it as one (the hub is woken
// once, not once per frame), and the hub hands it on to each other endpoint as one.
TEST(CanLocalBus, ABatchIsOneDatagramToTheHubAndOneFromItToEachOtherEndpoint) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto sender = open_local(dir.file("bus"));
  const int listener = connect_raw(dir.file("bus"));
  ASSERT_GE(listener, 0);
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 2; }));
  std::vector<can_frame> cycle;
  for (int i = 0; i < 8; ++i) cycle.push_back(frame(static_cast<canid_t>(0x201 + i), static_cast<std::uint8_t>(i)));
  ASSERT_EQ(sender->send_batch(cycle), cycle.size());
  const std::vector<can_frame> got = receive_datagram(listener);
  ASSERT_EQ(got.size(), cycle.size()) << "the hub handed the batch on in more than one datagram";
  for (std::size_t i = 0; i < got.size(); ++i) EXPECT_EQ(got[i].can_id, cycle[i].can_id) << "frame " << i;
  // The hub publishes its counters after each round, once it has handed the round on.
  EXPECT_TRUE(eventually([&] { return hub.counters().frames_forwarded == cycle.size(); }))
      << hub.counters().frames_forwarded;

  // And what the endpoint sent was one datagram: a hub that is a raw peer reads it so.
  RawHub raw(dir.file("peer"));
  ASSERT_GE(raw.peer, 0);
  std::vector<can_frame> longer(kMaxFramesPerDatagram + 8, frame(0x300, 1));
  ASSERT_EQ(raw.endpoint->send_batch(longer), longer.size());
  EXPECT_EQ(receive_datagram(raw.peer).size(), kMaxFramesPerDatagram) << "the first datagram: as many frames as one holds";
  EXPECT_EQ(receive_datagram(raw.peer).size(), 8u) << "the second: the rest";
  ::close(listener);
}

// A datagram is whole frames or nothing: one with a bad frame among good ones, or with more
// frames than a datagram may hold, is dropped whole and counted, by the hub and by an endpoint.
TEST(CanLocalBus, ADatagramWithABadFrameOrTooManyIsDroppedWholeByTheHubAndByAnEndpoint) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto receiver = open_local(dir.file("bus"));
  const int raw = connect_raw(dir.file("bus"));
  ASSERT_GE(raw, 0);
  can_frame bad_dlc = frame(0x111, 0);
  bad_dlc.can_dlc = 12;
  const can_frame good_then_bad[2] = {frame(0x101, 1), bad_dlc};
  const std::vector<can_frame> too_many(kMaxFramesPerDatagram + 1, frame(0x102, 2));
  const can_frame three[3] = {frame(0x103, 3), frame(0x104, 4), frame(0x105, 5)};
  ASSERT_EQ(::send(raw, good_then_bad, sizeof good_then_bad, 0), static_cast<ssize_t>(sizeof good_then_bad));
  ASSERT_EQ(::send(raw, too_many.data(), too_many.size() * sizeof(can_frame), 0),
            static_cast<ssize_t>(too_many.size() * sizeof(can_frame)));
  ASSERT_EQ(::send(raw, three, sizeof three, 0), static_cast<ssize_t>(sizeof three));
  can_frame got{};
  for (canid_t id : {0x103u, 0x104u, 0x105u}) {
    ASSERT_TRUE(receiver->receive(got, kArrives_ns));
    EXPECT_EQ(got.can_id, id) << "a frame of a dropped datagram came through, or the order changed";
  }
  EXPECT_FALSE(receiver->receive(got, kAbsent_ns));
  EXPECT_TRUE(eventually([&] {
    const auto c = hub.counters();
    return c.datagrams_malformed == 2 && c.frames_forwarded == 3;
  })) << hub.counters().datagrams_malformed << " malformed, " << hub.counters().frames_forwarded << " forwarded";
  ::close(raw);

  // An endpoint whose hub (a raw peer here) sends the same keeps only the whole, good datagram.
  RawHub peer(dir.file("peer"));
  ASSERT_GE(peer.peer, 0);
  ASSERT_EQ(::send(peer.peer, good_then_bad, sizeof good_then_bad, 0), static_cast<ssize_t>(sizeof good_then_bad));
  ASSERT_EQ(::send(peer.peer, too_many.data(), too_many.size() * sizeof(can_frame), 0),
            static_cast<ssize_t>(too_many.size() * sizeof(can_frame)));
  ASSERT_EQ(::send(peer.peer, three, sizeof three, 0), static_cast<ssize_t>(sizeof three));
  for (canid_t id : {0x103u, 0x104u, 0x105u}) {
    ASSERT_TRUE(peer.endpoint->receive(got, kArrives_ns));
    EXPECT_EQ(got.can_id, id) << "the endpoint kept a frame of a dropped datagram";
  }
  EXPECT_FALSE(peer.endpoint->receive(got, kAbsent_ns));
}

// The hub takes what its endpoints queued in rounds of at most 1024 frames, and hands each
// round on in batches: several senders' batches, larger than a round together, still reach
// every other endpoint whole, each sender's frames in its order.
TEST(CanLocalBus, SeveralSendersBatchesLargerThanARoundArriveWholeAndEachInItsOrder) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  constexpr int kSenders = 3, kFrames = 250;  // each batch fits a sender's socket buffer (~270 frames)
  std::vector<std::unique_ptr<Bus>> senders;
  for (int s = 0; s < kSenders; ++s) senders.push_back(open_local(dir.file("bus")));
  auto receiver = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == kSenders + 1; }));
  std::vector<std::vector<can_frame>> batches(kSenders);
  for (int s = 0; s < kSenders; ++s) {
    for (int i = 0; i < kFrames; ++i) {
      can_frame f = frame(static_cast<canid_t>(0x100 + s), static_cast<std::uint8_t>(i));
      f.can_dlc = 2;
      f.data[1] = static_cast<std::uint8_t>(i >> 8);
      batches[s].push_back(f);
    }
  }
  std::vector<std::thread> threads;
  for (int s = 0; s < kSenders; ++s)
    threads.emplace_back([&, s] { EXPECT_EQ(senders[s]->send_batch(batches[s]), batches[s].size()); });
  std::vector<int> next(kSenders, 0);
  can_frame got{};
  for (int k = 0; k < kSenders * kFrames; ++k) {
    ASSERT_TRUE(receiver->receive(got, kArrives_ns)) << "frame " << k;
    const int s = static_cast<int>(got.can_id) - 0x100;
    ASSERT_TRUE(s >= 0 && s < kSenders) << std::hex << got.can_id;
    EXPECT_EQ(got.data[0] | (got.data[1] << 8), next[s]) << "sender " << s;
    ++next[s];
  }
  for (auto& t : threads) t.join();
  EXPECT_EQ(next, std::vector<int>(kSenders, kFrames));
  EXPECT_FALSE(receiver->receive(got, kAbsent_ns)) << "a frame delivered twice";
  for (int s = 0; s < kSenders; ++s) {  // each sender hears the others' frames, never its own
    for (int k = 0; k < (kSenders - 1) * kFrames; ++k) {
      ASSERT_TRUE(senders[s]->receive(got, kArrives_ns)) << "sender " << s << ", frame " << k;
      EXPECT_NE(got.can_id, static_cast<canid_t>(0x100 + s)) << "sender " << s << " heard itself";
    }
  }
  EXPECT_EQ(hub.counters().deliveries_dropped, 0u);
}

// An endpoint takes what its hub queued in one go; what is no frame in that go is skipped and
// the frames around it still arrive, and a close after them is seen once they are taken. The
// hub here is a protocol-level peer that writes whatever it likes.
TEST(CanLocalBus, AnEndpointSkipsDatagramsThatAreNoFrameAmongGoodOnesAndThenSeesTheClose) {
  TempDir dir;
  const std::string path = dir.file("bus");
  const int listener = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
  ASSERT_GE(listener, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
  ASSERT_EQ(::bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ASSERT_EQ(::listen(listener, 1), 0);
  auto endpoint = open_local(path);
  const int hub = ::accept(listener, nullptr, nullptr);
  ASSERT_GE(hub, 0);
  const can_frame first = frame(0x181, 1), second = frame(0x182, 2);
  const char shorty[5] = {1, 2, 3, 4, 5};
  char longer[sizeof(can_frame) + 4] = {};
  can_frame bad_dlc = frame(0x111, 0);
  bad_dlc.can_dlc = 12;
  ASSERT_EQ(::send(hub, &first, sizeof first, 0), static_cast<ssize_t>(sizeof first));
  ASSERT_EQ(::send(hub, shorty, sizeof shorty, 0), 5);
  ASSERT_EQ(::send(hub, longer, sizeof longer, 0), static_cast<ssize_t>(sizeof longer));
  ASSERT_EQ(::send(hub, &bad_dlc, sizeof bad_dlc, 0), static_cast<ssize_t>(sizeof bad_dlc));
  ASSERT_EQ(::send(hub, &second, sizeof second, 0), static_cast<ssize_t>(sizeof second));
  ::close(hub);  // queued after the frames
  can_frame got{};
  ASSERT_TRUE(endpoint->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x181u);
  ASSERT_TRUE(endpoint->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x182u);
  try {
    endpoint->receive(got, kArrives_ns);
    FAIL() << "no BusError after the last frame";
  } catch (const BusError& e) {
    EXPECT_THAT(e.what(), HasSubstr("hub closed the connection"));
  }
  ::close(listener);
}

TEST(CanLocalBus, ABatchToAStoppedHubThrowsHubClosed) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 1; }));
  hub.stop();
  const std::vector<can_frame> batch(3, frame(0x100, 1));
  try {
    // The first write may still land in the socket's buffer; a later one sees the close.
    for (int i = 0; i < 100; ++i) a->send_batch(batch);
    FAIL() << "no BusError";
  } catch (const BusError& e) {
    EXPECT_THAT(e.what(), HasSubstr("hub closed the connection"));
  }
}

TEST(CanLocalBus, SurvivesAnEndpointDying) {
  ThreeEndpoints bus;
  ASSERT_TRUE(bus.connected());
  auto& [dir, hub, a, b, c] = bus;
  b.reset();  // closes its socket, as a crashed process would
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 2; }));
  ASSERT_TRUE(a->send(frame(0x321, 7)));
  can_frame got{};
  ASSERT_TRUE(c->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x321u);
  EXPECT_EQ(hub.counters().endpoints_closed, 1u);
}

// Driver::caller (pa10-sim hosts its hub so): no thread of the hub's own; the host's loop
// polls the hub's descriptors and calls relay(), and nothing moves between its rounds.
TEST(CanLocalBus, AHubDrivenByItsHostsLoopAcceptsRelaysAndLetsAClosedEndpointGoOnlyInItsRounds) {
  TempDir dir;
  LocalHub hub(dir.file("bus"), LocalHub::Driver::caller);
  std::vector<pollfd> fds;
  fds.reserve(LocalHub::kMaxEndpoints + 1);
  std::size_t relayed = 0;
  const auto rounds_until = [&](auto done) {
    for (int i = 0; i < 200 && !done(); ++i) {
      fds.clear();
      hub.add_poll_fds(fds);
      if (::poll(fds.data(), fds.size(), 25) > 0) relayed += hub.relay(fds);
    }
    return done();
  };
  auto a = open_bus("local:" + dir.file("bus"));
  auto b = open_bus("local:" + dir.file("bus"));
  EXPECT_EQ(hub.endpoint_count(), 0u) << "accepted only in a round";
  ASSERT_TRUE(rounds_until([&] { return hub.endpoint_count() == 2; }));

  ASSERT_TRUE(a->send(frame(0x181, 9)));
  can_frame got{};
  EXPECT_FALSE(b->receive(got, kAbsent_ns)) << "relayed without a round";
  ASSERT_TRUE(rounds_until([&] { return relayed == 1; }));
  ASSERT_TRUE(b->receive(got, 0)) << "there once relay() returned";
  EXPECT_EQ(got.can_id, 0x181u);
  EXPECT_EQ(got.data[0], 9);
  EXPECT_FALSE(a->receive(got, 0)) << "not back to its sender";

  a.reset();
  ASSERT_TRUE(rounds_until([&] { return hub.endpoint_count() == 1; }));
  const LocalHub::Counters c = hub.counters();
  EXPECT_EQ(c.frames_forwarded, 1u);
  EXPECT_EQ(c.deliveries, 1u);
  EXPECT_EQ(c.endpoints_closed, 1u);
  hub.stop();
  EXPECT_EQ(hub.endpoint_count(), 0u);
  EXPECT_THROW(b->receive(got, kArrives_ns), BusError) << "the endpoint sees the hub close";
}

TEST(CanLocalBus, ServesAtMostMaxEndpointsAndClosesMoreAtOnceSoAFloodOfConnectionsCannotStallIt) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  std::vector<std::unique_ptr<Bus>> endpoints;
  for (std::size_t i = 0; i < LocalHub::kMaxEndpoints + 20; ++i) endpoints.push_back(open_local(dir.file("bus")));
  ASSERT_TRUE(eventually([&] { return hub.counters().endpoints_refused == 20u; })) << hub.counters().endpoints_refused;
  EXPECT_EQ(hub.endpoint_count(), LocalHub::kMaxEndpoints);
  // The ones served still talk to each other.
  ASSERT_TRUE(endpoints[0]->send(frame(0x181, 1)));
  can_frame got{};
  EXPECT_TRUE(endpoints[1]->receive(got, kArrives_ns));
}

TEST(CanLocalBus, TheHubSocketIsItsUsersOnly) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  struct stat st {};
  ASSERT_EQ(::stat(dir.file("bus").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 077, 0u) << "group or others may connect: " << std::oct << (st.st_mode & 0777);
}

TEST(CanLocalBus, ASlowEndpointLosesFramesWithoutBlockingTheOthers) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto sender = open_local(dir.file("bus"));
  auto asleep = open_local(dir.file("bus"));  // never reads: its socket buffer fills up
  auto reader = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 3; }));
  constexpr int kFrames = 10000;  // far more than any socket buffer holds
  can_frame got{};
  for (int i = 0; i < kFrames; ++i) {
    ASSERT_TRUE(sender->send(frame(0x181, static_cast<std::uint8_t>(i))));
    ASSERT_TRUE(reader->receive(got, kArrives_ns)) << "frame " << i;
    ASSERT_EQ(got.data[0], static_cast<std::uint8_t>(i));
  }
  // The hub publishes its counters after each poll round: wait for the last one.
  EXPECT_TRUE(eventually([&] {
    const auto c = hub.counters();
    return c.deliveries + c.deliveries_dropped == 2u * kFrames;
  }));
  EXPECT_GT(hub.counters().deliveries_dropped, 0u);
}

TEST(CanLocalBus, DropsShortLongAndBadDlcDatagramsAndCountsThem) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto receiver = open_local(dir.file("bus"));
  // A raw client that writes whatever it likes.
  const int raw = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
  ASSERT_GE(raw, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, dir.file("bus").c_str(), sizeof address.sun_path - 1);
  ASSERT_EQ(::connect(raw, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  const char shorty[5] = {1, 2, 3, 4, 5};
  ASSERT_EQ(::send(raw, shorty, sizeof shorty, 0), 5);
  char longer[sizeof(can_frame) + 4] = {};
  ASSERT_EQ(::send(raw, longer, sizeof longer, 0), static_cast<ssize_t>(sizeof longer));
  can_frame bad_dlc = frame(0x111, 0);
  bad_dlc.can_dlc = 12;
  ASSERT_EQ(::send(raw, &bad_dlc, sizeof bad_dlc, 0), static_cast<ssize_t>(sizeof bad_dlc));
  const can_frame good = frame(0x222, 9);
  ASSERT_EQ(::send(raw, &good, sizeof good, 0), static_cast<ssize_t>(sizeof good));

  can_frame got{};
  ASSERT_TRUE(receiver->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x222u);  // the first frame through is the good one
  EXPECT_TRUE(eventually([&] { return hub.counters().datagrams_malformed == 3; }))
      << hub.counters().datagrams_malformed;
  ::close(raw);
}

TEST(CanLocalBus, AppliesFiltersLikeSocketCan) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  const FrameFilter only_tpdo1[] = {{0x180, 0x780}};
  auto b = open_local(dir.file("bus"), only_tpdo1);
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 2; }));
  a->send(frame(0x080, 1));
  a->send(frame(0x181, 2));
  can_frame got{};
  ASSERT_TRUE(b->receive(got, kArrives_ns));
  EXPECT_EQ(got.can_id, 0x181u);
  EXPECT_FALSE(b->receive(got, kAbsent_ns));
}

// An endpoint's filters go to the hub (as a SocketCAN socket's go to the kernel): the hub
// neither copies it other frames nor wakes it for them, and what passes still arrives in order.
TEST(CanLocalBus, TheHubAppliesAnEndpointsFiltersAndCopiesItNothingElse) {
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  const FrameFilter sync_and_node_5[] = {{0x080, CAN_SFF_MASK}, {0x005, 0x7f}};
  auto b = open_local(dir.file("bus"), sync_and_node_5);
  auto everything = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 3 && hub.counters().filters_set == 1; }));
  const std::vector<can_frame> traffic{frame(0x080, 1), frame(0x181, 2), frame(0x185, 3), frame(0x706, 4),
                                       frame(0x705, 5), frame(0x201, 6)};
  ASSERT_EQ(a->send_batch(traffic), traffic.size());
  can_frame got{};
  for (const canid_t id : {0x080u, 0x185u, 0x705u}) {
    ASSERT_TRUE(b->receive(got, kArrives_ns));
    EXPECT_EQ(got.can_id, id);
  }
  EXPECT_FALSE(b->receive(got, kAbsent_ns));
  for (const can_frame& sent : traffic) {
    ASSERT_TRUE(everything->receive(got, kArrives_ns));
    EXPECT_EQ(got.can_id, sent.can_id) << "an endpoint without filters gets every frame";
  }
  // Copies made: 6 to `everything`, 3 to b; the other 3 were kept from b by its filters.
  EXPECT_TRUE(eventually([&] { return hub.counters().deliveries == 9; })) << hub.counters().deliveries;
  EXPECT_EQ(hub.counters().frames_filtered, 3u);
  EXPECT_EQ(hub.counters().datagrams_malformed, 0u) << "the filter list is no frame";
}

TEST(CanLocalBus, ReceiveOnAStoppedHubThrowsHubClosed) {
  TempDir dir;
  auto hub = std::make_unique<LocalHub>(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub->endpoint_count() == 1; }));
  hub->stop();
  can_frame got{};
  try {
    a->receive(got, kArrives_ns);
    FAIL() << "expected BusError";
  } catch (const BusError& e) {
    EXPECT_THAT(e.what(), HasSubstr("hub closed"));
  }
}

TEST(CanLocalBus, ReplacesAStaleSocketFileButRefusesALiveHub) {
  TempDir dir;
  {
    LocalHub first(dir.file("bus"));
    EXPECT_THROW(LocalHub second(dir.file("bus")), BusError);
  }
  // Leave a stale socket file behind, as a killed hub does.
  const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
  sockaddr_un address{};
  address.sun_family = AF_UNIX;
  std::strncpy(address.sun_path, dir.file("bus").c_str(), sizeof address.sun_path - 1);
  ASSERT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof address), 0);
  ::close(fd);
  LocalHub replacement(dir.file("bus"));
  auto a = open_local(dir.file("bus"));
  EXPECT_TRUE(eventually([&] { return replacement.endpoint_count() == 1; }));
}

TEST(CanBusSpec, UnknownSchemeNamesBothValidForms) {
  try {
    open_bus("can0");
    FAIL() << "expected BusError";
  } catch (const BusError& e) {
    EXPECT_THAT(e.what(), HasSubstr("'can0'"));
    EXPECT_THAT(e.what(), HasSubstr("socketcan:<interface>"));
    EXPECT_THAT(e.what(), HasSubstr("local:<socket path>"));
  }
  EXPECT_THROW(open_bus("tcp:1.2.3.4"), BusError);
  EXPECT_THROW(open_bus(""), BusError);
}

TEST(CanBusSpec, MissingPathOrInterfaceIsAnError) {
  EXPECT_THAT([] { open_bus("local:"); }, ::testing::ThrowsMessage<BusError>(HasSubstr("no socket path")));
  EXPECT_THAT([] { open_bus("socketcan:"); }, ::testing::ThrowsMessage<BusError>(HasSubstr("no interface name")));
}

TEST(CanBusSpec, LocalWithoutAHubSaysHowToStartOne) {
  TempDir dir;
  try {
    open_bus("local:" + dir.file("nobody"));
    FAIL() << "expected BusError";
  } catch (const BusError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no hub listening"));
    EXPECT_THAT(e.what(), HasSubstr("rtm-canhub"));
  }
}

TEST(CanBusSpec, SocketCanUnavailableSaysSoAndNamesTheLocalBus) {
  const int probe = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  if (probe >= 0) {
    ::close(probe);
    GTEST_SKIP() << "this kernel has SocketCAN; the socketcan-labelled tests cover it";
  }
  ASSERT_EQ(errno, EAFNOSUPPORT);
  try {
    open_bus("socketcan:vcan0");
    FAIL() << "expected BusError";
  } catch (const BusError& e) {
    EXPECT_THAT(e.what(), HasSubstr("no SocketCAN support"));
    EXPECT_THAT(e.what(), HasSubstr("local:<path>"));
    EXPECT_THAT(e.what(), HasSubstr("socketcan:vcan0"));
  }
}

TEST(CanHubProcess, ForwardsFramesAndStopsCleanlyOnSigterm) {
  TempDir dir;
  int out[2];
  ASSERT_EQ(::pipe(out), 0);
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    ::dup2(out[1], STDOUT_FILENO);
    ::close(out[0]);
    ::execl(RTM_CANHUB_EXECUTABLE, "rtm-canhub", dir.file("bus").c_str(), nullptr);
    ::_exit(127);
  }
  ::close(out[1]);
  struct Reaper {  // the hub process is stopped whatever the test outcome
    pid_t pid;
    ~Reaper() {
      if (pid > 0) {
        ::kill(pid, SIGKILL);
        ::waitpid(pid, nullptr, 0);
      }
    }
  } reaper{pid};
  char line[256] = {};
  ssize_t got_bytes = 0;
  while (got_bytes < static_cast<ssize_t>(sizeof line) - 1) {
    const ssize_t n = ::read(out[0], line + got_bytes, 1);
    if (n <= 0 || line[got_bytes] == '\n') break;
    got_bytes += n;
  }
  ASSERT_THAT(line, HasSubstr("listening on"));

  auto a = open_bus("local:" + dir.file("bus"));
  auto b = open_bus("local:" + dir.file("bus"));
  can_frame got{};
  // b may connect after a's frame went out: resend until one arrives.
  bool arrived = false;
  for (int i = 0; i < 50 && !arrived; ++i) {
    a->send(frame(0x7AA, 1));
    arrived = b->receive(got, 100'000'000);
  }
  ASSERT_TRUE(arrived);
  EXPECT_EQ(got.can_id, 0x7AAu);

  ASSERT_EQ(::kill(pid, SIGTERM), 0);
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  reaper.pid = 0;
  EXPECT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0);
  EXPECT_FALSE(std::filesystem::exists(dir.file("bus")));
  ::close(out[0]);
}

TEST(CanHubProcess, UsageErrorWithoutAPath) {
  const pid_t pid = ::fork();
  ASSERT_GE(pid, 0);
  if (pid == 0) {
    const int devnull = ::open("/dev/null", O_WRONLY);
    ::dup2(devnull, STDERR_FILENO);
    ::execl(RTM_CANHUB_EXECUTABLE, "rtm-canhub", nullptr);
    ::_exit(127);
  }
  int status = 0;
  ASSERT_EQ(::waitpid(pid, &status, 0), pid);
  EXPECT_EQ(WEXITSTATUS(status), 2);
}

// A sensor's frames reach its loop through a listener's receive thread: with a real-time
// priority for the path (the runner sets it from --rt-priority or chrt), that thread runs at
// it; without one, at SCHED_OTHER. Needs CAP_SYS_NICE for the first half.
TEST(CanReceiveThread, RunsAtThePathPriorityWhenTheProcessHasOne) {
  sched_param probe{};
  probe.sched_priority = 1;
  if (sched_setscheduler(0, SCHED_FIFO, &probe) != 0) GTEST_SKIP() << "SCHED_FIFO not allowed here";
  const sched_param other{};
  sched_setscheduler(0, SCHED_OTHER, &other);
  TempDir dir;
  LocalHub hub(dir.file("bus"));
  auto sender = open_local(dir.file("bus"));
  auto listener_bus = open_local(dir.file("bus"));
  ASSERT_TRUE(eventually([&] { return hub.endpoint_count() == 2; }));
  for (const int priority : {17, 0}) {
    set_path_thread_priority(priority);
    std::atomic<int> policy{-1}, seen_priority{-1};
    ReceiveThread receiver;
    receiver.start(
        *listener_bus,
        [&](const can_frame&, std::int64_t) {
          int p = 0;
          sched_param param{};
          pthread_getschedparam(pthread_self(), &p, &param);
          seen_priority.store(param.sched_priority);
          policy.store(p);
        },
        [](const BusError&) {});
    ASSERT_TRUE(eventually([&] {
      sender->send(frame(0x181, 1));
      return policy.load() != -1;
    }));
    receiver.stop();
    EXPECT_EQ(policy.load(), priority > 0 ? SCHED_FIFO : SCHED_OTHER) << priority;
    EXPECT_EQ(seen_priority.load(), priority);
  }
  EXPECT_THROW(set_path_thread_priority(100), std::invalid_argument);
  EXPECT_EQ(path_thread_priority(), 0);
}

}  // namespace
}  // namespace rtm::can
