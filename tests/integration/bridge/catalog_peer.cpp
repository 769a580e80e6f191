// catalog_peer [OPTION...] DOMAIN SPACE STEP...: a space's catalog on a DdsLink of its own process
// (UDP only, lease 1500 ms unless --lease-ms), as another bridge's: the test's own participants would get its samples
// handed over in memory. Each STEP is a comma-separated list of "+NAME" (announce NAME) and "-NAME"
// (withdraw NAME): the first is done at once, each next one on SIGHUP. Exits on SIGTERM.
//
// The options make it an intruder on a link (tests/e2e/containers/run.sh), printing what it gets:
//   --pki DIR         joins secured with the files of DIR (deploy/pki.sh's layout) ...
//   --member NAME     ... of member NAME (default SPACE)
//   --peers H,H       unicast discovery of these hosts (DdsOptions::initial_peers)
//   --as S,S          announces each "+NAME" as space S (catalog and description writers of its
//                     own, as a forger would: URS.Diagnostic's description), for each S, instead
//                     of as SPACE
//   --call S/SERVICE  calls SERVICE of space S (operation "echo") once a report, three times
//   --snoop S,S       then reads the requests to space S and writes replies to it (endpoints of
//                     its own on urs/rpc/S/request and urs/rpc/S/reply), for each S: prints
//                     "snooping", then what other participants matched and sent
//   --lease-ms N      its writers' liveliness lease and the one its readers ask for (default 1500);
//                     a reader asking for less than a writer offers never matches it
//   --report-ms N     every N ms, prints what it saw (default 1000):
//     "seen N: SPACE/NAME ..."                    the catalog entries it reads (when they change)
//     "call S/SERVICE: STATUS message"            each call's outcome
//     "snoop TOPIC: refused" | "snoop TOPIC: matched M, read R"  (when they change)
//     "request CALLER SERVICE.OPERATION"          a request that reached its own link
// Every line is flushed: docker logs reads them as they come.

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/log/Log.hpp>
#include <fastdds/dds/log/StdoutErrConsumer.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <iostream>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <tuple>
#include <vector>

#include "Diagnostic.pb.h"
#include "Federation.h"
#include "FederationPubSubTypes.h"
#include "urs/federation/dds_link.hpp"
#include "urs/federation/dds_security.hpp"
#include "urs/schema/schema.hpp"
#include "urs/util/cli.hpp"

namespace {

namespace fdds = eprosima::fastdds::dds;

std::mutex out_mutex;
void say(const std::string& line) {
  std::lock_guard lock(out_mutex);
  std::cout << line << std::endl;
}

std::vector<std::string> split(const std::string& list) {
  std::vector<std::string> parts;
  std::istringstream in(list);
  for (std::string part; std::getline(in, part, ',');) {
    if (!part.empty()) parts.push_back(part);
  }
  return parts;
}

// The topic `name` of the link's participant (the link registered its types), made if the link
// has not made it yet: made before the link, the link could not make it itself.
fdds::Topic* topic_of(fdds::DomainParticipant* participant, const std::string& name, const std::string& type) {
  if (auto* made = dynamic_cast<fdds::Topic*>(participant->lookup_topicdescription(name))) return made;
  return participant->create_topic(name, type, fdds::TOPIC_QOS_DEFAULT);
}

// Catalog entries written as any space, with URS.Diagnostic's real description under its real
// digest (so that a bridge taking them could offer them), in the link's keyed-state QoS
// (manual-by-topic liveliness, asserted by the link): what a forger would write. On a secured link
// (`own_partition`: the member's own) it first tries a writer in each forged space's partition and
// prints whether its own DDS made it ("forge urs/catalog in partition S: ..."), then writes in its
// own partition, where the others' DDS takes its samples and the bridges judge them.
class ForgedCatalog {
 public:
  ForgedCatalog(urs::federation::DdsLink& link, const std::string& own_partition,
                const std::vector<std::string>& spaces)
      : link_(link) {
    fdds::DataWriterQos qos = fdds::DATAWRITER_QOS_DEFAULT;
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = 1;
    qos.liveliness().kind = fdds::MANUAL_BY_TOPIC_LIVELINESS_QOS;
    qos.liveliness().lease_duration =
        eprosima::fastrtps::Duration_t(static_cast<double>(link.options().lease.count()) / 1000.0);
    fdds::DomainParticipant* participant = link.participant();
    for (const auto& space : own_partition.empty() ? std::vector<std::string>{} : spaces) {
      fdds::PublisherQos in_space = fdds::PUBLISHER_QOS_DEFAULT;
      in_space.partition().push_back(space.c_str());
      fdds::Publisher* publisher = participant->create_publisher(in_space);
      fdds::Topic* topic = topic_of(participant, "urs/catalog", urs::dds::ServiceEntryPubSubType().getName());
      fdds::DataWriter* writer =
          publisher != nullptr && topic != nullptr ? publisher->create_datawriter(topic, qos) : nullptr;
      say("forge urs/catalog in partition " + space + ": " + (writer != nullptr ? "made" : "refused by its own DDS"));
      if (writer != nullptr) publisher->delete_datawriter(writer);
      if (publisher != nullptr) participant->delete_publisher(publisher);
    }
    fdds::PublisherQos own = fdds::PUBLISHER_QOS_DEFAULT;
    if (!own_partition.empty()) own.partition().push_back(own_partition.c_str());
    publisher_ = participant->create_publisher(own);
    for (auto [writer, name, type] :
         {std::tuple{&entries_, "urs/catalog", urs::dds::ServiceEntryPubSubType().getName()},
          std::tuple{&descriptions_, "urs/interface", urs::dds::InterfaceDescriptionPubSubType().getName()}}) {
      auto* topic = topic_of(link.participant(), name, type);
      if (publisher_ != nullptr && topic != nullptr) *writer = publisher_->create_datawriter(topic, qos);
      if (*writer == nullptr) throw std::runtime_error(std::string("cannot write on ") + name);
      link_.keep_alive(*writer);
    }
    const std::string described = urs::schema::descriptor_set_for(*URS::Diagnostic_echo_Request::descriptor()->file());
    urs::dds::InterfaceDescription description;
    digest_ = urs::federation::description_digest(described);
    description.digest(digest_);
    description.descriptor_set(std::vector<uint8_t>(described.begin(), described.end()));
    descriptions_->write(&description);
  }
  ~ForgedCatalog() {
    for (auto* writer : {entries_, descriptions_}) {
      link_.let_go(writer);
      publisher_->delete_datawriter(writer);
    }
    link_.participant()->delete_publisher(publisher_);
  }
  ForgedCatalog(const ForgedCatalog&) = delete;
  ForgedCatalog& operator=(const ForgedCatalog&) = delete;
  void write(const std::string& space, const std::string& name, const std::string& bridge) {
    urs::dds::ServiceEntry entry;
    entry.space(space);
    entry.name(name);
    entry.interface_name("URS.Diagnostic");
    entry.origin("camus");
    entry.bridge(bridge);
    entry.interface_digest(digest_);
    entries_->write(&entry);
  }
  void dispose(const std::string& space, const std::string& name) {
    urs::dds::ServiceEntry entry;
    entry.space(space);
    entry.name(name);
    entries_->dispose(&entry, fdds::HANDLE_NIL);
  }

 private:
  urs::federation::DdsLink& link_;
  fdds::Publisher* publisher_ = nullptr;
  fdds::DataWriter* entries_ = nullptr;
  fdds::DataWriter* descriptions_ = nullptr;
  std::string digest_;
};

// Whether an instance handle (a GUID: the participant's prefix first) is of another participant
// than `own`: the endpoints of this process match each other too.
bool of_another(const eprosima::fastrtps::rtps::InstanceHandle_t& handle, const fdds::DomainParticipant* own) {
  return std::memcmp(handle.value, own->guid().guidPrefix.value, 12) != 0;
}

// A reader of the requests to `space` and a writer of the replies to it, on the link's participant,
// counting what other participants match and send.
class Snoop : public fdds::DataReaderListener, public fdds::DataWriterListener {
 public:
  Snoop(fdds::DomainParticipant* on, const std::string& space)
      : participant_(on), request_topic_("urs/rpc/" + space + "/request"), reply_topic_("urs/rpc/" + space + "/reply") {
    fdds::DataReaderQos reader_qos = fdds::DATAREADER_QOS_DEFAULT;
    reader_qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    reader_qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    subscriber_ = participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    publisher_ = participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    if (auto* topic = topic_of(participant_, request_topic_, urs::dds::CallRequestPubSubType().getName())) {
      reader_ = subscriber_->create_datareader(topic, reader_qos, this);
    }
    if (auto* topic = topic_of(participant_, reply_topic_, urs::dds::CallReplyPubSubType().getName())) {
      writer_ = publisher_->create_datawriter(topic, fdds::DATAWRITER_QOS_DEFAULT, this);
    }
  }
  ~Snoop() override {
    if (reader_ != nullptr) subscriber_->delete_datareader(reader_);
    if (writer_ != nullptr) publisher_->delete_datawriter(writer_);
    participant_->delete_subscriber(subscriber_);
    participant_->delete_publisher(publisher_);
  }
  Snoop(const Snoop&) = delete;
  Snoop& operator=(const Snoop&) = delete;

  // What it got, one line per endpoint: "snoop TOPIC: refused" or "snoop TOPIC: matched M, read R".
  std::vector<std::string> report() const {
    auto line = [](const std::string& topic, bool made, int matched, int read) {
      return "snoop " + topic + ": " +
             (made ? "matched " + std::to_string(matched) + ", read " + std::to_string(read) : std::string("refused"));
    };
    return {line(request_topic_, reader_ != nullptr, writers_matched_, requests_read_),
            line(reply_topic_, writer_ != nullptr, readers_matched_, 0)};
  }

  void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& status) override {
    if (of_another(status.last_publication_handle, participant_)) writers_matched_ += status.current_count_change;
  }
  void on_data_available(fdds::DataReader* reader) override {
    urs::dds::CallRequest request;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&request, &info) == ReturnCode_t::RETCODE_OK) {
      if (info.valid_data && of_another(info.publication_handle, participant_)) ++requests_read_;
    }
  }
  void on_publication_matched(fdds::DataWriter*, const fdds::PublicationMatchedStatus& status) override {
    if (of_another(status.last_subscription_handle, participant_)) readers_matched_ += status.current_count_change;
  }

 private:
  fdds::DomainParticipant* const participant_;
  const std::string request_topic_;
  const std::string reply_topic_;
  std::atomic<int> writers_matched_{0};
  std::atomic<int> readers_matched_{0};
  std::atomic<int> requests_read_{0};
  fdds::Subscriber* subscriber_ = nullptr;
  fdds::Publisher* publisher_ = nullptr;
  fdds::DataReader* reader_ = nullptr;
  fdds::DataWriter* writer_ = nullptr;
};

[[noreturn]] void usage() {
  std::cerr << "usage: catalog_peer [--pki DIR [--member NAME]] [--peers H,H] [--as S,S] [--call S/SERVICE]\n"
               "                    [--snoop S,S] [--lease-ms N] [--report-ms N] DOMAIN SPACE STEP...\n";
  std::exit(2);
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> flags;
  int next = 1;
  for (; next + 1 < argc && std::string(argv[next]).rfind("--", 0) == 0; next += 2) {
    const std::string flag = argv[next];
    if (flag != "--pki" && flag != "--member" && flag != "--peers" && flag != "--as" && flag != "--call" &&
        flag != "--snoop" && flag != "--report-ms" && flag != "--lease-ms") {
      usage();
    }
    flags[flag] = argv[next + 1];
  }
  if (argc - next < 3) usage();
  urs::util::block_shutdown_signals(true);  // every thread (Fast DDS's too) inherits the mask
  // Fast DDS's own log (the refusals this peer provokes) goes to stderr: its log thread would
  // otherwise write into stdout at the moment say() does, and cut one of the report lines the
  // tests grep for.
  auto fastdds_log = std::make_unique<eprosima::fastdds::dds::StdoutErrConsumer>();
  fastdds_log->stderr_threshold(eprosima::fastdds::dds::Log::Kind::Info);
  eprosima::fastdds::dds::Log::ClearConsumers();
  eprosima::fastdds::dds::Log::RegisterConsumer(std::move(fastdds_log));
  urs::federation::DdsOptions options;
  options.domain = static_cast<uint32_t>(std::stoul(argv[next]));
  options.space = argv[next + 1];
  options.bridge = "bridge-" + options.space;
  options.lease = std::chrono::milliseconds(flags["--lease-ms"].empty() ? 1500 : std::stoul(flags["--lease-ms"]));
  options.udp_only = true;
  options.initial_peers = split(flags["--peers"]);
  if (!flags["--pki"].empty()) {
    options.security = urs::federation::security_from_folder(
        flags["--pki"], flags["--member"].empty() ? options.space : flags["--member"]);
  }
  const bool reporting =
      !flags["--report-ms"].empty() || !flags["--call"].empty() || !flags["--snoop"].empty() || !flags["--as"].empty();
  urs::federation::DdsLink link(
      options, [] {},
      [](urs::call::Request request, urs::call::Responder) {
        say("request " + request.caller.space + " " + request.service + "." + request.operation);
      });
  const std::vector<std::string> as = split(flags["--as"]);
  std::unique_ptr<ForgedCatalog> forged;
  if (!as.empty()) {
    forged = std::make_unique<ForgedCatalog>(
        link, options.security.enabled() ? (flags["--member"].empty() ? options.space : flags["--member"]) : "", as);
  }

  next += 2;
  auto step = [&] {
    if (next >= argc) return;
    std::istringstream actions(argv[next++]);
    for (std::string action; std::getline(actions, action, ',');) {
      const std::string name = action.substr(1);
      for (const auto& space : as) {
        if (action[0] == '-') {
          forged->dispose(space, name);
        } else {
          forged->write(space, name, options.bridge);
        }
        say(action + " as " + space);
      }
      if (!as.empty()) continue;
      if (action[0] == '-') {
        link.withdraw(name);
      } else {
        urs::federation::ServiceEntry entry;
        entry.name = name;
        entry.interface_name = "URS.Diagnostic";
        entry.descriptor_set = "a description";
        link.announce(entry);
      }
      say(action);
    }
  };
  step();

  // The reports, from a thread of their own: calls block.
  constexpr int kCalls = 3;
  std::mutex mutex;
  std::condition_variable stopping;
  bool stop = false;
  std::thread reporter;
  if (reporting) {
    const auto period =
        std::chrono::milliseconds(flags["--report-ms"].empty() ? 1000 : std::stoul(flags["--report-ms"]));
    const std::string target = flags["--call"];
    reporter = std::thread([&, period, target] {
      std::vector<std::unique_ptr<Snoop>> snoops;
      bool snooping = false;
      int calls = 0;
      std::string seen = "-";
      std::map<std::string, std::string> snooped;
      std::unique_lock lock(mutex);
      while (!stop) {
        lock.unlock();
        std::set<std::string> entries;
        for (const auto& entry : link.catalog()) entries.insert(entry.space + "/" + entry.name);
        std::string now = "seen " + std::to_string(entries.size()) + ":";
        for (const auto& entry : entries) now += " " + entry;
        if (now != seen) say(seen = now);
        // The calls first, then the snoops: its own calls would be read by its own reader.
        if (const auto slash = target.find('/'); slash != std::string::npos && calls < kCalls) {
          const auto reply =
              link.call(target.substr(0, slash), target.substr(slash + 1), "echo", "", std::chrono::seconds(3));
          say("call " + target + ": " + std::string(urs::call::status_name(reply.status)) + " " + reply.message);
          ++calls;
        } else if (!snooping) {
          for (const auto& space : split(flags["--snoop"]))
            snoops.push_back(std::make_unique<Snoop>(link.participant(), space));
          snooping = true;
          say("snooping");
        }
        for (auto& snoop : snoops) {
          for (const auto& line : snoop->report()) {
            const std::string topic = line.substr(0, line.find(':'));
            if (snooped[topic] != line) say(snooped[topic] = line);
          }
        }
        lock.lock();
        stopping.wait_for(lock, period, [&] { return stop; });
      }
    });
  }
  urs::util::wait_for_shutdown(step);
  if (reporter.joinable()) {
    {
      std::lock_guard lock(mutex);
      stop = true;
    }
    stopping.notify_all();
    reporter.join();
  }
  return 0;
}
