// The DDS link between bridges (urs::federation::DdsLink, StateLink) on real Fast DDS participants,
// UDP only as between containers: what one space sees of another's catalog and state when that
// space withdraws a service, or its bridge dies while others live on.

#include "urs/federation/dds_link.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <condition_variable>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <future>
#include <mutex>
#include <optional>
#include <set>
#include <vector>

#include "dds_domain.hpp"
#include "process.hpp"
#include "urs/federation/state_link.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

constexpr auto kLease = 1500ms;

federation::DdsOptions link_options(uint32_t domain, const std::string& space) {
  federation::DdsOptions options;
  options.domain = domain;
  options.space = space;
  options.bridge = "bridge-" + space;
  options.lease = kLease;
  options.udp_only = true;
  return options;
}

federation::ServiceEntry entry_named(const std::string& name) {
  federation::ServiceEntry entry;
  entry.name = name;
  entry.interface_name = "URS.Diagnostic";
  entry.descriptor_set = "a description";
  return entry;
}

// A space's bridge in a process of its own: its link offers service "svc" and shares component
// "robot" until the process is killed. Forked before this process makes any DDS entity or thread.
pid_t bridge_process(uint32_t domain, const std::string& space) {
  const pid_t child = fork();
  if (child != 0) return child;
  try {  // never back into the test runner
    federation::DdsLink link(
        link_options(domain, space), [] {}, [](call::Request, call::Responder) {});
    federation::StateLink state(link, {}, std::nullopt);
    link.announce(entry_named("svc"));
    state.set_component({space, "robot", "rtc", "Active", "Robot", "host", {}});
    while (true) pause();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bridge of %s: %s\n", space.c_str(), e.what());
  }
  _exit(1);
}

class LinkedSpaces : public ::testing::Test {
 protected:
  void TearDown() override {
    for (pid_t pid : children_) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
    }
  }
  std::vector<pid_t> children_;
};

// Two other spaces' bridges live; one is killed. Its service and its state end within the
// liveliness lease, not with its participant's lease (20 s by default), calls to it fail at once,
// and the other's stay. With AUTOMATIC liveliness, Fast DDS 2.9 kept asserting the dead bridge's
// writers as long as the other asserted its own: they ended only with the participant lease.
TEST_F(LinkedSpaces, AKilledBridgesServicesAndStateEndWithinTheLeaseWhileAnotherLives) {
  const DdsDomains domains;
  children_.push_back(bridge_process(domains[0], "a"));
  children_.push_back(bridge_process(domains[0], "b"));
  std::mutex mutex;
  std::set<std::string> components;  // "<space>/<name>" of the live ones
  federation::StateHandlers handlers;
  handlers.component = [&](const federation::ComponentState& c, bool alive) {
    std::lock_guard lock(mutex);
    if (alive) {
      components.insert(c.space + "/" + c.name);
    } else {
      components.erase(c.space + "/" + c.name);
    }
  };
  federation::DdsLink seeing(
      link_options(domains[0], "r"), [] {}, [](call::Request, call::Responder) {});
  federation::StateLink state(seeing, handlers, std::nullopt);
  auto services = [&] {
    std::set<std::string> found;
    for (const auto& entry : seeing.catalog()) found.insert(entry.space + "/" + entry.name);
    return found;
  };
  auto live_components = [&] {
    std::lock_guard lock(mutex);
    return components;
  };
  const std::set<std::string> both{"a/svc", "b/svc"};
  ASSERT_TRUE(wait_until([&] { return services() == both; }, 20s));
  ASSERT_TRUE(wait_until([&] { return live_components() == std::set<std::string>{"a/robot", "b/robot"}; }, 20s));

  kill(children_[0], SIGKILL);
  const auto killed = Clock::now();
  EXPECT_TRUE(wait_until([&] { return services() == std::set<std::string>{"b/svc"}; }, 30s));
  const auto ended = Clock::now() - killed;
  EXPECT_TRUE(wait_until([&] { return live_components() == std::set<std::string>{"b/robot"}; }, 30s));
  std::cout << "a's service ended " << std::chrono::duration_cast<std::chrono::milliseconds>(ended).count()
            << " ms after the kill (lease " << kLease.count() << " ms)\n";
  EXPECT_LT(ended, kLease * 4);
  const auto refused = seeing.call("a", "svc", "echo", "", 5s);
  EXPECT_EQ(refused.status, call::Status::UNAVAILABLE) << refused.message;
  EXPECT_NE(refused.message.find("lost its liveliness"), std::string::npos) << refused.message;
}

// A service withdrawn in its space leaves the other spaces' catalogs while its bridge lives on,
// and what that bridge announces afterwards still arrives.
TEST(DdsCatalog, AWithdrawnEntryLeavesTheOtherSpaces) {
  const DdsDomains domains;
  federation::DdsLink offering(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  federation::DdsLink seeing(
      link_options(domains[0], "b"), [] {}, [](call::Request, call::Responder) {});
  auto names = [&] {
    std::set<std::string> found;
    for (const auto& entry : seeing.catalog()) found.insert(entry.space + "/" + entry.name);
    return found;
  };
  offering.announce(entry_named("first"));
  ASSERT_TRUE(wait_until([&] { return names() == std::set<std::string>{"a/first"}; }, 10s));
  offering.withdraw("first");
  offering.announce(entry_named("second"));
  EXPECT_TRUE(wait_until([&] { return names() == std::set<std::string>{"a/second"}; }, 10s))
      << "seen: " << ::testing::PrintToString(names());
  offering.withdraw("never announced");  // refused by DDS, harmlessly
}

// The same between processes, as between two bridges (two participants of one process hand their
// samples over in memory). Space "a" offers "kept" and "gone", then withdraws "gone" and offers
// "new" at once (a dead RT provider replaced by a new one), then announces both again. A withdrawal
// reaches another process as a dispose and an unregistration without payload, which the catalog
// reader's dynamic payload pool refused: Fast DDS 2.9's reliable reader then waited for that sample
// forever and showed nothing "a" wrote after it ("new" never came), and "kept" went as soon as "a"
// announced it again.
TEST(DdsCatalog, AWithdrawalAndANewEntryReachAnotherProcessAndWhatFollowsThem) {
  const DdsDomains domains;
  const std::string dir = make_temp_dir("catalog-peer");
  Process peer({URS_CATALOG_PEER_BIN, std::to_string(domains[0]), "a", "+kept,+gone", "-gone,+new", "+kept,+new"},
               dir + "/peer.log");
  std::atomic<int> arrivals{0};  // catalog samples arrived
  federation::DdsLink seeing(
      link_options(domains[0], "b"), [&] { ++arrivals; }, [](call::Request, call::Responder) {});
  auto names = [&] {
    std::set<std::string> found;
    for (const auto& entry : seeing.catalog()) found.insert(entry.space + "/" + entry.name);
    return found;
  };
  ASSERT_TRUE(wait_until(
      [&] {
        return names() == std::set<std::string>{"a/gone", "a/kept"};
      },
      20s))
      << "seen: " << ::testing::PrintToString(names()) << "\n"
      << peer.log();
  peer.signal(SIGHUP);  // withdraws "gone", offers "new"
  const std::set<std::string> after{"a/kept", "a/new"};
  EXPECT_TRUE(wait_until([&] { return names() == after; }, 20s))
      << "seen: " << ::testing::PrintToString(names()) << "\n"
      << peer.log();
  const int before = arrivals;
  peer.signal(SIGHUP);  // announces both again
  EXPECT_TRUE(wait_until([&] { return arrivals > before; }, 20s)) << "the second announcement never arrived";
  EXPECT_TRUE(wait_until([&] { return peer.log().find("+new\n+kept\n+new") != std::string::npos; }, 20s)) << peer.log();
  EXPECT_EQ(names(), after);
  std::filesystem::remove_all(dir);
}

// call_async() on `link` to service "svc" of `space`: the future of its outcome, or nullopt when
// the link refused to start it without waiting for a match.
std::optional<std::future<call::Reply>> call_async(federation::DdsLink& link, const std::string& space,
                                                   const std::string& operation, std::string payload,
                                                   std::chrono::milliseconds deadline) {
  auto promise = std::make_shared<std::promise<call::Reply>>();
  auto future = promise->get_future();
  if (!link.call_async(space, "svc", operation, std::move(payload), deadline, "",
                       [promise](call::Reply reply) { promise->set_value(std::move(reply)); })) {
    return std::nullopt;
  }
  return future;
}

// A space's bridge whose handler answers "echo" and keeps every other call unanswered.
class SlowSpace {
 public:
  SlowSpace(uint32_t domain, const std::string& space)
      : link_(std::make_unique<federation::DdsLink>(
            link_options(domain, space), [] {},
            [this](call::Request request, call::Responder responder) {
              if (request.operation == "echo") {
                responder.reply(call::Reply::success(request.payload));
                return;
              }
              std::lock_guard lock(mutex_);
              unanswered_.push_back(std::move(responder));
              arrived_.notify_all();
            })) {}
  bool wait_for_call() {
    std::unique_lock lock(mutex_);
    return arrived_.wait_for(lock, 30s, [&] { return !unanswered_.empty(); });
  }
  void leave() { link_.reset(); }

 private:
  std::mutex mutex_;
  std::condition_variable arrived_;
  std::vector<call::Responder> unanswered_;
  std::unique_ptr<federation::DdsLink> link_;  // last: its handler uses the above
};

// An asynchronous call is started only to a space whose bridge is matched already (the first call
// to it, which call() makes, waits for discovery); its payload crosses as it came, and the reply's.
TEST(DdsCalls, AnAsyncCallStartsOnlyToAMatchedSpaceAndPassesItsBytes) {
  const DdsDomains domains;
  SlowSpace here(domains[0], "here");
  federation::DdsLink calling(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  const std::string bytes("\0\xff not a message\0", 17);
  std::string payload = bytes;
  EXPECT_FALSE(calling.call_async("here", "svc", "echo", std::move(payload), 10s, "",
                                  [](call::Reply) { ADD_FAILURE() << "answered a call not started"; }));
  EXPECT_EQ(payload, bytes) << "a call not started keeps its payload";

  const auto first = calling.call("here", "svc", "echo", "first", 10s);
  ASSERT_EQ(first.status, call::Status::OK) << first.message;
  auto echoed = call_async(calling, "here", "echo", bytes, 10s);
  ASSERT_TRUE(echoed) << "a matched space's call was not started";
  ASSERT_EQ(echoed->wait_for(10s), std::future_status::ready);
  const auto result = echoed->get();
  ASSERT_EQ(result.status, call::Status::OK) << result.message;
  EXPECT_EQ(result.payload, bytes);
}

// An asynchronous call nobody answers ends at its deadline, as a blocking one does.
TEST(DdsCalls, AnAsyncCallUnansweredEndsAtItsDeadline) {
  const DdsDomains domains;
  SlowSpace slow(domains[0], "slow");
  federation::DdsLink calling(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  ASSERT_EQ(calling.call("slow", "svc", "echo", "", 10s).status, call::Status::OK);

  const auto started = Clock::now();
  auto late = call_async(calling, "slow", "sleep", "", 300ms);
  ASSERT_TRUE(late);
  ASSERT_EQ(late->wait_for(10s), std::future_status::ready);
  EXPECT_GE(Clock::now() - started, 300ms);
  const auto result = late->get();
  EXPECT_EQ(result.status, call::Status::DEADLINE_EXCEEDED) << result.message;
  EXPECT_EQ(result.message, "no reply from space slow for svc.sleep within 300 ms");

  const auto blocking = calling.call("slow", "svc", "sleep", "", 200ms);
  EXPECT_EQ(blocking.status, call::Status::DEADLINE_EXCEEDED) << blocking.message;
  EXPECT_EQ(blocking.message, "no reply from space slow for svc.sleep within 200 ms");
}

// The called space's bridge leaving ends its asynchronous calls at once, not at their deadline.
TEST(DdsCalls, AnAsyncCallEndsProviderGoneWhenTheCalledBridgeLeaves) {
  const DdsDomains domains;
  SlowSpace slow(domains[0], "slow");
  federation::DdsLink calling(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  ASSERT_EQ(calling.call("slow", "svc", "echo", "", 10s).status, call::Status::OK);

  auto pending = call_async(calling, "slow", "sleep", "", 60s);
  ASSERT_TRUE(pending);
  ASSERT_TRUE(slow.wait_for_call()) << "the call never arrived";
  slow.leave();
  ASSERT_EQ(pending->wait_for(20s), std::future_status::ready);
  const auto result = pending->get();
  EXPECT_EQ(result.status, call::Status::PROVIDER_GONE) << result.message;
  EXPECT_EQ(result.message, "the bridge of space slow left during the call");
}

// A link destroyed with asynchronous calls waiting for replies answers them first.
TEST(DdsCalls, ALinkStoppingAnswersItsAsyncCallsUnavailable) {
  const DdsDomains domains;
  SlowSpace slow(domains[0], "slow");
  auto calling = std::make_unique<federation::DdsLink>(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  ASSERT_EQ(calling->call("slow", "svc", "echo", "", 10s).status, call::Status::OK);

  auto pending = call_async(*calling, "slow", "sleep", "", 60s);
  ASSERT_TRUE(pending);
  ASSERT_TRUE(slow.wait_for_call()) << "the call never arrived";
  calling.reset();
  ASSERT_EQ(pending->wait_for(0s), std::future_status::ready) << "the link went away leaving its call unanswered";
  const auto result = pending->get();
  EXPECT_EQ(result.status, call::Status::UNAVAILABLE) << result.message;
  EXPECT_EQ(result.message, "bridge stopping");
}

// A call to a space whose bridge is not matched yet waits for it, woken by the request writer's
// match (no polling), and is answered once it is there; a space nobody serves is UNAVAILABLE after
// the match wait (not DEADLINE_EXCEEDED).
TEST(DdsCalls, ACallWaitsForItsSpacesBridgeToMatchAndOnlyThatLong) {
  const DdsDomains domains;
  federation::DdsLink calling(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  auto answer = std::async(std::launch::async, [&] { return calling.call("late", "svc", "echo", "ping", 10s); });
  federation::DdsLink late(
      link_options(domains[0], "late"), [] {},
      [](call::Request request, call::Responder responder) {
        responder.reply(call::Reply::success(request.operation + ":" + request.payload));
      });
  ASSERT_EQ(answer.wait_for(30s), std::future_status::ready);
  const auto result = answer.get();
  EXPECT_EQ(result.status, call::Status::OK) << result.message;
  EXPECT_EQ(result.payload, "echo:ping");

  const auto nobody = calling.call("nobody", "svc", "echo", "", 10s);
  EXPECT_EQ(nobody.status, call::Status::UNAVAILABLE) << nobody.message;
  EXPECT_NE(nobody.message.find("no bridge of it matched"), std::string::npos) << nobody.message;
}

// A reply given on the DDS listener thread (inside the handler, or by dropping the responder
// there) is written by the link's replier thread and reaches its caller: written on the listener
// thread, the first reply to a space creates its reply writer there, which can deadlock Fast DDS
// 2.9's in-process delivery. Each calling space makes the replier create another reply writer.
TEST(DdsCalls, RepliesGivenOnTheListenerThreadReachTheirCallers) {
  const DdsDomains domains;
  std::mutex mutex;
  std::vector<call::Request> received;
  federation::DdsLink replier(
      link_options(domains[0], "here"), [] {},
      [&](call::Request request, call::Responder responder) {
        {
          std::lock_guard lock(mutex);
          received.push_back(request);
        }
        if (request.operation == "drop") return;  // the responder is dropped unanswered, here
        responder.reply(call::Reply::success(request.operation + ":" + request.payload));
      });
  for (const std::string space : {"a", "b", "c"}) {
    federation::DdsLink calling(
        link_options(domains[0], space), [] {}, [](call::Request, call::Responder) {});
    for (int i = 0; i < 3; ++i) {
      const auto echoed = calling.call("here", "svc", "echo", space + std::to_string(i), 10s);
      ASSERT_EQ(echoed.status, call::Status::OK) << space << i << ": " << echoed.message;
      EXPECT_EQ(echoed.payload, "echo:" + space + std::to_string(i));
    }
    const auto dropped = calling.call("here", "svc", "drop", "", 10s);
    EXPECT_EQ(dropped.status, call::Status::INTERNAL) << dropped.message;
    EXPECT_EQ(dropped.message, "provider dropped the request");
  }
  std::lock_guard lock(mutex);
  ASSERT_EQ(received.size(), 12u);
  // The served request as the neutral call: the calling space as the domain vouches for it, and
  // the deadline the caller sent, counted from the arrival.
  EXPECT_EQ(received[0].service, "svc");
  EXPECT_EQ(received[0].caller.space, "a");
  EXPECT_EQ(received[0].caller.name, "dds:a");
  EXPECT_EQ(received[0].caller.role, "bridge");
  EXPECT_TRUE(received[0].has_deadline());
  EXPECT_FALSE(received[0].oneway);
}

// A space's bridge in a process of its own that answers every call with its payload, until the
// process is killed. Forked before this process makes any DDS entity or thread.
pid_t echo_process(uint32_t domain, const std::string& space) {
  const pid_t child = fork();
  if (child != 0) return child;
  try {  // never back into the test runner
    federation::DdsLink link(
        link_options(domain, space), [] {},
        [](call::Request request, call::Responder responder) {
          responder.reply(call::Reply::success(std::move(request.payload)));
        });
    while (true) pause();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "bridge of %s: %s\n", space.c_str(), e.what());
  }
  _exit(1);
}

// Each call registers its request and reply as DDS instances, and a retired one holds its
// instance until the readers acknowledged the retirement. More calls in a row than a writer keeps
// in flight (4096), to a bridge in another process (acknowledgements travel as messages, not in
// memory), are all served: with Fast DDS's default heartbeat period (3 s) the readers acknowledged
// too late, and the 4,097th call within 3 s was refused ("could not be written").
TEST_F(LinkedSpaces, MoreCallsInARowThanCallsInFlightAreAllServed) {
  const DdsDomains domains;
  children_.push_back(echo_process(domains[0], "far"));
  federation::DdsLink calling(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  ASSERT_TRUE(wait_until([&] { return calling.call("far", "svc", "echo", "first", 1s).ok(); }, 30s));
  for (int i = 0; i < 5000; ++i) {
    const auto echoed = calling.call("far", "svc", "echo", std::to_string(i), 10s);
    ASSERT_EQ(echoed.status, call::Status::OK) << "call " << i << ": " << echoed.message;
    ASSERT_EQ(echoed.payload, std::to_string(i));
  }
}

// A link destroyed while one of its calls waits for a reply ends that call first ("bridge
// stopping"), while its writers still exist, rather than leaving it to wake on deleted entities.
TEST(DdsCalls, ALinkStoppingEndsItsCallsInProgressFirst) {
  const DdsDomains domains;
  std::mutex mutex;
  std::condition_variable arrived;
  std::vector<call::Responder> unanswered;  // the replier never answers
  federation::DdsLink replier(
      link_options(domains[0], "slow"), [] {},
      [&](call::Request, call::Responder responder) {
        std::lock_guard lock(mutex);
        unanswered.push_back(std::move(responder));
        arrived.notify_all();
      });
  auto calling = std::make_unique<federation::DdsLink>(
      link_options(domains[0], "a"), [] {}, [](call::Request, call::Responder) {});
  auto answer = std::async(std::launch::async, [&] { return calling->call("slow", "svc", "sleep", "", 60s); });
  {
    std::unique_lock lock(mutex);
    ASSERT_TRUE(arrived.wait_for(lock, 30s, [&] { return !unanswered.empty(); })) << "the call never arrived";
  }
  calling.reset();  // returns once the call has ended
  // call() has returned or is returning (the future is ready a moment after it returns); "bridge
  // stopping" rather than the 60 s deadline says the stopping link ended it.
  ASSERT_EQ(answer.wait_for(10s), std::future_status::ready);
  const auto result = answer.get();
  EXPECT_EQ(result.status, call::Status::UNAVAILABLE) << result.message;
  EXPECT_EQ(result.message, "bridge stopping");
}

}  // namespace
}  // namespace urs::test
