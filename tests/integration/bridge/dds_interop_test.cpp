// URSLink's DDS link against peers it did not write: Eclipse Cyclone DDS through its Python binding
// (tests/integration/bridge/cyclone/urs_peer.py, installed from PyPI into a venv under the build
// folder by tests/support/cyclone_venv.sh; the tests skip, saying so, only when PyPI cannot be
// reached), and plain Fast DDS endpoints written by hand.
//
// Calls: no request is lost to discovery timing (a replier that matches the caller's request
// writer after the request was written still gets it), and no replier executes a request whose
// caller stopped waiting, nor one request twice.

#include <gtest/gtest.h>

#include <csignal>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <filesystem>
#include <fstream>
#include <future>
#include <mutex>
#include <sstream>
#include <thread>

#include "Diagnostic.pb.h"
#include "Federation.h"
#include "FederationPubSubTypes.h"
#include "camus.pb.h"
#include "dds_domain.hpp"
#include "naming_service.hpp"
#include "process.hpp"
#include "urs/federation/dds_link.hpp"
#include "urs/planet/client.hpp"
#include "urs/schema/schema.hpp"

namespace urs::test {
namespace {

using namespace std::chrono_literals;
namespace fdds = eprosima::fastdds::dds;

// A plain Fast DDS participant with one endpoint on a call topic of the link, with the QoS
// docs/federation.md gives for calls (reliable, transient-local, keep-last 1 per request).
class RawEndpoint {
 public:
  RawEndpoint(uint32_t domain, const std::string& topic_name) {
    auto* factory = fdds::DomainParticipantFactory::get_instance();
    participant_ = factory->create_participant(domain, fdds::PARTICIPANT_QOS_DEFAULT);
    type_.register_type(participant_);
    topic_ = participant_->create_topic(topic_name, type_.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  }
  ~RawEndpoint() {
    participant_->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_);
  }
  template <class Qos>
  static Qos rpc(Qos qos) {
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = 1;
    return qos;
  }
  // A reader of the requests that never answers: the caller's request writer matches it at once.
  void read() {
    reader_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT)
                  ->create_datareader(topic_, rpc(fdds::DATAREADER_QOS_DEFAULT));
  }
  std::size_t requests_seen() {
    dds::CallRequest sample;
    fdds::SampleInfo info;
    while (reader_->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data) ++seen_;
    }
    return seen_;
  }
  void write() {
    writer_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT)
                  ->create_datawriter(topic_, rpc(fdds::DATAWRITER_QOS_DEFAULT));
  }
  fdds::DataWriter* writer() { return writer_; }

 private:
  fdds::DomainParticipant* participant_ = nullptr;
  fdds::TypeSupport type_{new dds::CallRequestPubSubType()};
  fdds::Topic* topic_ = nullptr;
  fdds::DataReader* reader_ = nullptr;
  fdds::DataWriter* writer_ = nullptr;
  std::size_t seen_ = 0;
};

federation::DdsOptions link_options(uint32_t domain, const std::string& space) {
  federation::DdsOptions options;
  options.domain = domain;
  options.space = space;
  options.bridge = "bridge-" + space;
  options.lease = 1500ms;
  return options;
}

// The lines a peer printed that start with `word`, without it.
std::vector<std::string> lines_of(const std::string& log, const std::string& word) {
  std::vector<std::string> found;
  std::istringstream lines(log);
  for (std::string line; std::getline(lines, line);) {
    if (line.rfind(word + " ", 0) == 0) found.push_back(line.substr(word.size() + 1));
  }
  return found;
}

class CyclonePeer : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = make_temp_dir("interop");
    const auto venv = run_command({URS_CYCLONE_VENV_SCRIPT, URS_CYCLONE_VENV}, 600s);
    if (venv.exit_code == 77) GTEST_SKIP() << "Cyclone DDS's Python binding cannot be installed: " << venv.err;
    ASSERT_EQ(venv.exit_code, 0) << venv.err;
    python_ = venv.out.substr(0, venv.out.find('\n'));
  }
  void TearDown() override {
    if (HasFailure()) {
      for (auto& [name, peer] : peers_) std::cerr << "---- " << name << "\n" << peer->log();
    }
    peers_.clear();
    std::filesystem::remove_all(dir_);
  }

  // Starts urs_peer.py `args` as `name`; with `ready`, waits for its "ready" line.
  Process& peer(const std::string& name, std::vector<std::string> args, bool ready = true) {
    std::vector<std::string> argv{python_, URS_CYCLONE_PEER};
    argv.insert(argv.end(), args.begin(), args.end());
    auto& made = peers_[name] = std::make_unique<Process>(argv, dir_ + "/" + name + ".log");
    if (ready) {
      EXPECT_TRUE(wait_until([&] { return made->log().find("ready\n") != std::string::npos || !made->running(); }, 30s))
          << made->log();
    }
    return *made;
  }
  std::vector<std::string> executed(const std::string& name) { return lines_of(peers_.at(name)->log(), "executed"); }

  const DdsDomains domains_{1};
  uint32_t domain() const { return domains_[0]; }
  std::string dir_;
  std::string python_;
  std::map<std::string, std::unique_ptr<Process>> peers_;
};

// The caller's request writer has matched a reader already (here one that never answers), so the
// request goes out at once; the replier, another vendor's, appears only afterwards. It gets the
// request all the same, and answers it. A replier appearing after the call ended never sees it.
TEST_F(CyclonePeer, AReplierMatchingAfterTheRequestWasWrittenStillGetsIt) {
  federation::DdsLink caller(
      link_options(domain(), "req"), [] {}, [](call::Request, call::Responder) {});
  RawEndpoint decoy(domain(), "urs/rpc/rep/request");
  decoy.read();
  auto answer = std::async(std::launch::async, [&] { return caller.call("rep", "svc", "echo", "first call", 30s); });
  ASSERT_TRUE(wait_until([&] { return decoy.requests_seen() == 1; }, 10s));

  peer("replier", {"replier", std::to_string(domain()), "rep"});
  const auto first = answer.get();
  ASSERT_EQ(first.status, call::Status::OK) << first.message;
  EXPECT_EQ(first.payload, "first call");
  ASSERT_EQ(executed("replier").size(), 1u);
  const std::string first_id = executed("replier")[0];

  // A second replier, alone once the first is gone, answers a new call and never the first.
  peer("late", {"replier", std::to_string(domain()), "rep"});
  peers_.erase("replier");
  const auto second = caller.call("rep", "svc", "echo", "second call", 30s);
  ASSERT_EQ(second.status, call::Status::OK) << second.message;
  EXPECT_EQ(second.payload, "second call");
  ASSERT_EQ(executed("late").size(), 1u) << peers_["late"]->log();
  EXPECT_NE(executed("late")[0], first_id);
}

// A call whose caller gave up (its deadline passed with no replier) is not executed by a replier
// that appears afterwards.
TEST_F(CyclonePeer, ARequestItsCallerGaveUpOnIsNeverExecuted) {
  federation::DdsLink caller(
      link_options(domain(), "req"), [] {}, [](call::Request, call::Responder) {});
  RawEndpoint decoy(domain(), "urs/rpc/rep/request");
  decoy.read();
  auto abandoned =
      std::async(std::launch::async, [&] { return caller.call("rep", "svc", "echo", "nobody answers", 3s); });
  ASSERT_TRUE(wait_until([&] { return decoy.requests_seen() == 1; }, 10s));  // the request was out
  const auto gave_up = abandoned.get();
  ASSERT_EQ(gave_up.status, call::Status::DEADLINE_EXCEEDED) << gave_up.message;

  peer("replier", {"replier", std::to_string(domain()), "rep"});
  const auto answered = caller.call("rep", "svc", "echo", "answered", 30s);
  ASSERT_EQ(answered.status, call::Status::OK) << answered.message;
  EXPECT_EQ(answered.payload, "answered");
  EXPECT_EQ(executed("replier").size(), 1u);
}

// A bridge paused (SIGSTOP) for 5 s, longer than its liveliness lease (3 s), on a link that has
// run for a while, UDP only as between containers: another vendor's reader of its catalog is
// matched to it after the pause. Its participant lease (20 s by default) outlasts the pause and
// Cyclone's own lease (10 s), so Cyclone never drops it. With a participant lease of 3 s, Cyclone
// dropped the paused bridge and never matched it again (every run that had run for 5 s or more
// before the pause; one paused right after discovery was still found again).
TEST_F(CyclonePeer, AForeignReaderFindsABridgeAgainAfterAPause) {
  NamingService naming(dir_ + "/naming");
  std::ofstream(dir_ + "/bridge.yaml") << "name: bridge-p\ndds:\n  domain: " << domain()
                                       << "\n  lease_ms: 3000\n  udp_only: true\n";
  Process bridge({URS_BRIDGE_BIN, "--space", "p", "--config", dir_ + "/bridge.yaml", "--naming", naming.address(),
                  "--host", "phost", "--ready-file", dir_ + "/bridge.ready"},
                 dir_ + "/bridge.log");
  ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/bridge.ready"); }, 20s)) << bridge.log();
  Process& reader = peer("catalog", {"catalog", std::to_string(domain())}, false);
  auto matched = [&] {
    const auto lines = lines_of(reader.log(), "matched");
    return lines.empty() ? std::string("0") : lines.back();
  };
  ASSERT_TRUE(wait_until([&] { return matched() == "1"; }, 30s)) << reader.log();

  // Scenario time, not a wait for anything: the link runs for 10 s, then the bridge stops for 5 s.
  std::this_thread::sleep_for(10s);
  bridge.signal(SIGSTOP);
  std::this_thread::sleep_for(5s);
  bridge.signal(SIGCONT);
  EXPECT_TRUE(wait_until([&] { return matched() == "1"; }, 20s)) << reader.log() << bridge.log();
}

// Another vendor's bridge: a Cyclone DDS peer offers a service as a bridge would (its description
// and catalog entry, with the catalog's QoS and manual-by-topic liveliness) and serves its calls.
// A CAMUS space's bridge imports it as "cy/diag", a CAMUS client's call reaches the peer and its
// answer comes back; when the peer dies, the service leaves the space once the lease passes.
TEST_F(CyclonePeer, AServiceItOffersIsImportedAndServedByABridge) {
  const std::string descriptor_file = dir_ + "/diagnostic.desc";
  std::ofstream(descriptor_file, std::ios::binary)
      << schema::descriptor_set_for(*URS::Diagnostic_echo_Request::descriptor()->file());
  Process server({URS_SERVER_BIN, "--space", "kr", "--listen", "127.0.0.1:0", "--port-file", dir_ + "/port"},
                 dir_ + "/server.log");
  ASSERT_TRUE(wait_until([&] { return !read_text(dir_ + "/port").empty(); }, 10s)) << server.log();
  const uint16_t port = static_cast<uint16_t>(std::stoi(read_text(dir_ + "/port")));
  std::ofstream(dir_ + "/bridge.yaml")
      << "name: bridge-kr\ndds:\n  domain: " << domain()
      << "\n  lease_ms: 3000\n  hold_lost_ms: 0\n  udp_only: true\n  import: {as_rtc: \"\"}\n";
  Process bridge({URS_BRIDGE_BIN, "--space", "kr", "--config", dir_ + "/bridge.yaml", "--server",
                  "127.0.0.1:" + std::to_string(port), "--ready-file", dir_ + "/bridge.ready"},
                 dir_ + "/bridge.log");
  ASSERT_TRUE(wait_until([&] { return std::filesystem::exists(dir_ + "/bridge.ready"); }, 20s)) << bridge.log();
  planet::ClientOptions options;
  options.port = port;
  options.peer_name = "tester";
  planet::Client client(options);
  client.start();
  ASSERT_TRUE(client.wait_connected(5s)) << client.last_error();
  auto imported = [&] {
    camus::ListRequest request;
    request.set_pattern("cy/*");
    camus::ListReply listed;
    const auto r = client.call("camus.registry", "List", request.SerializeAsString(), 2s);
    return r.ok() && listed.ParseFromString(r.payload) && listed.services_size() == 1 &&
           listed.services(0).name() == "cy/diag" && listed.services(0).interface() == "URS.Diagnostic";
  };

  peer("offer", {"offer", std::to_string(domain()), "cy", "diag", descriptor_file, "3000"});
  ASSERT_TRUE(wait_until(imported, 20s)) << bridge.log();
  URS::Diagnostic_echo_Request echo;
  echo.set_text("from CAMUS to Cyclone");
  const auto answer = client.call("cy/diag", "echo", echo.SerializeAsString(), 10s);
  ASSERT_EQ(answer.status, planet::OK) << answer.message << bridge.log();
  URS::Diagnostic_echo_Reply reply;
  ASSERT_TRUE(reply.ParseFromString(answer.payload));
  EXPECT_EQ(reply.result(), "from CAMUS to Cyclone");
  ASSERT_EQ(executed("offer").size(), 1u);
  EXPECT_EQ(executed("offer")[0].rfind("kr/bridge-kr/", 0), 0u) << executed("offer")[0];

  // Its writers' liveliness (3 s) ends it, well before Cyclone's participant lease (10 s) would
  // (hold_lost_ms: 0, so that the lost space's service leaves at once instead of staying, unreachable).
  peers_.at("offer")->kill9();
  const auto killed = std::chrono::steady_clock::now();
  ASSERT_TRUE(wait_until([&] { return !imported(); }, 15s)) << bridge.log();
  const auto gone = std::chrono::steady_clock::now() - killed;
  std::cout << "cy/diag left kr " << std::chrono::duration_cast<std::chrono::milliseconds>(gone).count()
            << " ms after the peer was killed (lease 3000 ms)\n";
  EXPECT_LT(gone, 7s);
}

// URSLink as the replier, a hand-written Fast DDS writer as the caller: a request delivered twice
// is executed once; one that arrives after its deadline (by its writer's clock) is not executed.
TEST(DdsReplier, ExecutesEachRequestOnceAndNoneAfterItsDeadline) {
  const DdsDomains domains;
  std::mutex mutex;
  std::vector<std::string> served;  // the payloads served: each request carries its id as payload
  federation::DdsLink replier(
      link_options(domains[0], "svc"), [] {},
      [&](call::Request request, call::Responder responder) {
        std::lock_guard lock(mutex);
        served.push_back(request.payload);
        responder.reply(call::Reply::success(request.payload));
      });
  auto served_now = [&] {
    std::lock_guard lock(mutex);
    return served;
  };
  RawEndpoint caller(domains[0], "urs/rpc/svc/request");
  caller.write();
  ASSERT_TRUE(wait_until(
      [&] {
        fdds::PublicationMatchedStatus status;
        caller.writer()->get_publication_matched_status(status);
        return status.current_count > 0;
      },
      10s));
  auto request = [](const std::string& id) {
    dds::CallRequest r;
    r.request_id(id);
    r.caller_space("other");
    r.service("svc");
    r.operation("echo");
    r.deadline_ms(5000);
    r.no_reply(true);
    r.payload(std::vector<uint8_t>(id.begin(), id.end()));
    return r;
  };
  auto once = request("other/b/1/1");
  ASSERT_TRUE(caller.writer()->write(&once));
  ASSERT_TRUE(wait_until([&] { return served_now().size() == 1; }, 10s));
  ASSERT_TRUE(caller.writer()->write(&once));  // delivered again, as after a re-match

  auto old = request("other/b/1/2");  // sent 60 s ago with a 5 s deadline
  eprosima::fastrtps::Time_t sent;
  eprosima::fastrtps::Time_t::now(sent);
  sent.seconds -= 60;
  ASSERT_EQ(caller.writer()->write_w_timestamp(&old, fdds::HANDLE_NIL, sent), ReturnCode_t::RETCODE_OK);

  auto fresh = request("other/b/1/3");          // requests arrive in order: once this one is served, the
  ASSERT_TRUE(caller.writer()->write(&fresh));  // two before it were handled
  ASSERT_TRUE(wait_until([&] { return served_now().size() >= 2; }, 10s));
  EXPECT_EQ(served_now(), (std::vector<std::string>{"other/b/1/1", "other/b/1/3"}));
}

}  // namespace
}  // namespace urs::test
