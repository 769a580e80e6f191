#include "urs/bridge/dds_link.hpp"

#include <netdb.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <condition_variable>
#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <fastdds/rtps/attributes/ServerAttributes.h>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>
#include <fastrtps/utils/IPLocator.h>
#include <cstdio>
#include <deque>
#include <future>
#include <map>
#include <mutex>
#include <random>
#include <set>
#include <stdexcept>

#include "Federation.h"
#include "FederationPubSubTypes.h"
#include "dds_identity.hpp"
#include "dds_qos.hpp"
#include "liveliness_asserter.hpp"
#include "urs/agent/agent.hpp"

namespace urs::bridge {

namespace fdds = eprosima::fastdds::dds;
namespace rtps = eprosima::fastrtps::rtps;
using Clock = std::chrono::steady_clock;

namespace {

constexpr const char* kCatalogTopic = "urs/catalog";
constexpr const char* kInterfaceTopic = "urs/interface";

// The key of a description on urs/interface: FNV-1a 64 of its bytes and their size, the same in
// every process (std::hash is not).
std::string digest_of(const std::string& bytes) {
  uint64_t hash = 14695981039346656037ull;
  for (unsigned char c : bytes) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  char text[40];
  std::snprintf(text, sizeof text, "%016llx-%zu", static_cast<unsigned long long>(hash), bytes.size());
  return text;
}

// Calls in flight per request or reply writer (instances it keeps registered): beyond, a call is
// refused rather than an older one's request dropped.
constexpr int32_t kRpcInFlight = 4096;
// How long a replier remembers the requests it executed (against a second delivery of one) and a
// oneway request stays available to a replier that matches late: requests carry their deadline,
// oneway ones none.
constexpr std::chrono::milliseconds kDefaultDeadline{10000};
// How long a call to a space waits for its request writer to match a bridge of that space
// (discovery, for the first call to it). The wait is on a condition variable the writer's
// matched-status listener signals, on a DDS listener thread: so call() and oneway() never run on
// one (nor on a Planet client's I/O thread, which they would hold up). The bridge calls them from
// its agent host's workers (CamusForwardingAgent) and CORBA's threads; what arrives over DDS
// (serve_remote) is only dispatched or sent on asynchronously.
constexpr std::chrono::milliseconds kMatchWait{2000};
// Executed request ids remembered at most (the oldest forgotten first).
constexpr std::size_t kRememberedRequests = 65536;

std::string request_topic(const std::string& space) { return "urs/rpc/" + space + "/request"; }
std::string reply_topic(const std::string& space) { return "urs/rpc/" + space + "/reply"; }

std::vector<uint8_t> bytes_of(const std::string& text) { return {text.begin(), text.end()}; }

std::string text_of(const std::vector<uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

// "HOST" or "HOST:PORT" -> the IPv4 address and port(s) of an initial peer.
std::vector<rtps::Locator_t> peer_locators(const std::string& peer, uint32_t domain) {
  std::string host = peer;
  std::vector<uint16_t> ports;
  const auto colon = peer.rfind(':');
  if (colon != std::string::npos) {
    host = peer.substr(0, colon);
    ports.push_back(static_cast<uint16_t>(std::stoi(peer.substr(colon + 1))));
  } else {
    // The metatraffic unicast ports of participants 0..4 of the domain (RTPS port mapping).
    for (uint32_t id = 0; id < 5; ++id) ports.push_back(static_cast<uint16_t>(7400 + 250 * domain + 10 + 2 * id));
  }
  addrinfo hints{};
  hints.ai_family = AF_INET;
  addrinfo* found = nullptr;
  if (getaddrinfo(host.c_str(), nullptr, &hints, &found) != 0 || found == nullptr) {
    throw std::runtime_error("DDS initial peer '" + peer + "': cannot resolve " + host);
  }
  char address[64] = {};
  getnameinfo(found->ai_addr, found->ai_addrlen, address, sizeof address, nullptr, 0, NI_NUMERICHOST);
  freeaddrinfo(found);
  std::vector<rtps::Locator_t> locators;
  for (uint16_t port : ports) {
    rtps::Locator_t locator;
    rtps::IPLocator::setIPv4(locator, address);
    locator.port = port;
    locators.push_back(locator);
  }
  return locators;
}

}  // namespace

struct DdsLink::Impl : public fdds::DataReaderListener, public std::enable_shared_from_this<DdsLink::Impl> {
  // A call waiting for its reply.
  struct Pending {
    std::string space;
    std::promise<call::Reply> promise;
  };
  // Follows a request writer's matched readers: wakes the callers waiting for the first one
  // (wait_matched), and notices the writer losing its last: the target space's bridge left.
  class RequestWriterListener : public fdds::DataWriterListener {
   public:
    RequestWriterListener(Impl& impl, std::string space) : impl_(impl), space_(std::move(space)) {}
    void on_publication_matched(fdds::DataWriter*, const fdds::PublicationMatchedStatus& status) override {
      {
        // Never held while DDS is called: this may run holding DDS's own locks.
        std::lock_guard lock(mutex_);
        matched_ = status.current_count;
      }
      matched_changed_.notify_all();
      if (status.current_count == 0 && status.current_count_change < 0) impl_.fail_pending(space_);
    }
    // Waits until the writer has a matched reader, or `until`, or the link closes (false). Blocks:
    // never on a DDS listener thread (the match it waits for would be reported on such a thread).
    bool wait_matched(Clock::time_point until) {
      std::unique_lock lock(mutex_);
      matched_changed_.wait_until(lock, until, [this] { return matched_ > 0 || impl_.closing; });
      return matched_ > 0 && !impl_.closing;
    }
    // Wakes the callers in wait_matched() (the link is closing).
    void wake() {
      { std::lock_guard lock(mutex_); }
      matched_changed_.notify_all();
    }

   private:
    Impl& impl_;
    const std::string space_;
    std::mutex mutex_;
    std::condition_variable matched_changed_;
    int32_t matched_ = 0;  // readers matched now
  };

  Impl(const DdsOptions& options, CatalogHandler on_catalog, CallHandler on_call)
      : options(options), on_catalog(std::move(on_catalog)), on_call(std::move(on_call)) {}

  // Set while this thread runs one of the link's reader listeners (on_data_available).
  static thread_local bool on_listener_thread;
  class OnListener {
   public:
    OnListener() : outer_(on_listener_thread) { on_listener_thread = true; }
    ~OnListener() { on_listener_thread = outer_; }
    OnListener(const OnListener&) = delete;
    OnListener& operator=(const OnListener&) = delete;

   private:
    bool outer_;
  };

  const DdsOptions& options;
  CatalogHandler on_catalog;
  CallHandler on_call;
  // The space each remote participant proved (the participant's listener): the callers of requests.
  DdsIdentities identities{options.security.enabled()};
  // Writes the replies given on the link's listener threads (responder_for).
  agent::WorkerPool replier{1};
  const std::string request_name = request_topic(options.space);  // this space's requests
  const std::string reply_name = reply_topic(options.space);      // replies to this space's calls
  // Part of every request id: ids stay unique across restarts of this bridge, so a replier that
  // remembers an earlier run's id never takes a new call for a duplicate.
  const std::string run = [] {
    std::random_device random;
    char text[20];
    std::snprintf(text, sizeof text, "%08x%08x", random(), random());
    return std::string(text);
  }();

  fdds::DomainParticipant* participant = nullptr;
  fdds::Publisher* publisher = nullptr;
  fdds::Subscriber* subscriber = nullptr;
  fdds::TypeSupport entry_type{new dds::ServiceEntryPubSubType()};
  fdds::TypeSupport interface_type{new dds::InterfaceDescriptionPubSubType()};
  fdds::TypeSupport request_type{new dds::CallRequestPubSubType()};
  fdds::TypeSupport reply_type{new dds::CallReplyPubSubType()};
  fdds::Topic* catalog_topic = nullptr;
  fdds::DataWriter* catalog_writer = nullptr;
  fdds::DataReader* catalog_reader = nullptr;
  fdds::DataWriter* interface_writer = nullptr;
  fdds::DataReader* interface_reader = nullptr;
  fdds::DataReader* request_reader = nullptr;
  fdds::DataReader* reply_reader = nullptr;

  // Calls in progress (call(), oneway()): the destructor wakes them and waits until none is left,
  // before it deletes what they use.
  std::atomic<bool> closing{false};
  std::mutex calls_mutex;  // guards calls_in_progress
  std::condition_variable calls_done;
  int calls_in_progress = 0;
  class InProgress {
   public:
    explicit InProgress(Impl& d) : d_(d) {
      std::lock_guard lock(d_.calls_mutex);
      admitted_ = !d_.closing;
      if (admitted_) ++d_.calls_in_progress;
    }
    ~InProgress() {
      if (!admitted_) return;
      std::lock_guard lock(d_.calls_mutex);
      if (--d_.calls_in_progress == 0) d_.calls_done.notify_all();
    }
    InProgress(const InProgress&) = delete;
    InProgress& operator=(const InProgress&) = delete;
    bool admitted() const { return admitted_; }

   private:
    Impl& d_;
    bool admitted_ = false;
  };

  std::mutex mutex;  // guards the maps below and entity creation
  std::map<std::string, fdds::Topic*> topics;
  struct RequestRoute {
    fdds::DataWriter* writer = nullptr;
    RequestWriterListener* listener = nullptr;  // owned by writer_listeners
  };
  std::map<std::string, RequestRoute> request_writers;     // by target space
  std::map<std::string, fdds::DataWriter*> reply_writers;  // by caller space
  std::vector<std::unique_ptr<RequestWriterListener>> writer_listeners;
  std::map<std::string, std::shared_ptr<Pending>> pending;  // by request id
  std::atomic<uint64_t> next_id{1};
  // Requests and replies still registered, each until nobody waits for it any more: then it is
  // unregistered, so a reader that matches later does not get it.
  struct Registered {
    Clock::time_point until;
    fdds::DataWriter* writer;
    std::string request_id;
    bool reply;
  };
  std::deque<Registered> registered;  // oneway requests and replies, by `until` within each kind
  // Requests this replier executed, against a second delivery (transient-local history sent again
  // to a reader that matched again): id -> until when it could arrive again.
  std::mutex executed_mutex;  // guards the three below
  std::map<std::string, Clock::time_point> executed;
  std::deque<std::pair<Clock::time_point, std::string>> executed_order;
  // Requests being served, by their instance on the request reader: when the caller unregisters
  // one (it has the reply, or gave up), its reply is retired at once.
  std::map<fdds::InstanceHandle_t, std::pair<std::string, Clock::time_point>> serving;

  std::mutex interfaces_mutex;
  std::map<std::string, Clock::time_point> interfaces_written;  // digest -> when last written

  mutable std::mutex catalog_mutex;  // guards dead_writers and writer_spaces
  std::set<fdds::InstanceHandle_t> dead_writers;  // catalog writers whose liveliness is lost
  std::map<fdds::InstanceHandle_t, std::string> writer_spaces;  // catalog writers seen, by space written

  // Asserts the keyed-state writers' liveliness (the link's and StateLink's); stopped first.
  std::unique_ptr<LivelinessAsserter> asserter;

  // True if catalog writers of `space` were seen and every one has lost its liveliness.
  bool space_lost(const std::string& space) const {
    std::lock_guard lock(catalog_mutex);
    bool seen = false;
    for (const auto& [writer, written] : writer_spaces) {
      if (written != space) continue;
      if (!dead_writers.count(writer)) return false;
      seen = true;
    }
    return seen;
  }

  // ---- entities ----

  fdds::Topic* topic(const std::string& name, fdds::TypeSupport& type) {
    auto it = topics.find(name);
    if (it != topics.end()) return it->second;
    fdds::Topic* made = participant->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    if (made == nullptr) throw std::runtime_error("DDS: cannot create topic " + name);
    topics[name] = made;
    return made;
  }

  // Reliable and transient-local, keyed by request id (keep-last 1 per instance): a reader that
  // matches a writer after a request or reply was written (discovery is not symmetric: a writer
  // may see a reader before the reader sees it, and a volatile reader then never gets what was
  // written in between) still receives it, as long as its writer keeps it registered. The same
  // on writers and readers, or they would not match.
  template <class Qos>
  static Qos rpc_qos(Qos qos) {
    qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    qos.durability().kind = fdds::TRANSIENT_LOCAL_DURABILITY_QOS;
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = 1;
    qos.resource_limits().max_instances = kRpcInFlight;
    qos.resource_limits().max_samples_per_instance = 1;
    qos.resource_limits().max_samples = kRpcInFlight;
    qos.resource_limits().allocated_samples = 16;
    return qos;
  }
  static fdds::DataWriterQos rpc_writer_qos() {
    fdds::DataWriterQos qos = rpc_qos(fdds::DATAWRITER_QOS_DEFAULT);
    // Sent from the calling thread: the asynchronous publisher's thread cost a wake-up per message
    // and spun on the writer's lock (docs/performance.md). Fast DDS 2.9 fragments large payloads
    // in this mode too.
    qos.publish_mode().kind = fdds::SYNCHRONOUS_PUBLISH_MODE;
    return qos;
  }
  static fdds::DataReaderQos rpc_reader_qos() { return rpc_qos(fdds::DATAREADER_QOS_DEFAULT); }

  // Caller holds `mutex`.
  RequestRoute request_writer(const std::string& space) {
    auto it = request_writers.find(space);
    if (it != request_writers.end()) return it->second;
    // The listener is the writer's from its creation on: no match goes unreported.
    auto listener = std::make_unique<RequestWriterListener>(*this, space);
    fdds::DataWriter* writer =
        publisher->create_datawriter(topic(request_topic(space), request_type), rpc_writer_qos(), listener.get());
    if (writer == nullptr) throw std::runtime_error("DDS: cannot write requests to space " + space);
    RequestRoute route{writer, listener.get()};
    writer_listeners.push_back(std::move(listener));
    request_writers[space] = route;
    return route;
  }
  fdds::DataWriter* reply_writer(const std::string& space) {
    auto it = reply_writers.find(space);
    if (it != reply_writers.end()) return it->second;
    fdds::DataWriter* writer = publisher->create_datawriter(topic(reply_topic(space), reply_type), rpc_writer_qos());
    if (writer == nullptr) throw std::runtime_error("DDS: cannot write replies to space " + space);
    reply_writers[space] = writer;
    return writer;
  }

  // The request (or reply) `id` is no longer waited for: unregistered, so that no reader matching
  // from now on gets it (one that has it already keeps it).
  static void retire(fdds::DataWriter* writer, const std::string& id, bool reply) {
    if (reply) {
      dds::CallReply key;
      key.request_id(id);
      writer->unregister_instance(&key, fdds::HANDLE_NIL);
    } else {
      dds::CallRequest key;
      key.request_id(id);
      writer->unregister_instance(&key, fdds::HANDLE_NIL);
    }
  }
  // Keeps `id` registered on `writer` until `until`, and retires what is due. Caller holds `mutex`.
  void retire_later(fdds::DataWriter* writer, const std::string& id, bool reply, Clock::time_point until) {
    const auto now = Clock::now();
    for (auto it = registered.begin(); it != registered.end();) {
      if (it->until > now) {
        ++it;
        continue;
      }
      retire(it->writer, it->request_id, it->reply);
      it = registered.erase(it);
    }
    registered.push_back({until, writer, id, reply});
  }

  std::string next_request_id() {
    return options.space + "/" + options.bridge + "/" + run + "/" + std::to_string(next_id++);
  }

  void fail_pending(const std::string& space) {
    std::vector<std::shared_ptr<Pending>> failed;
    {
      std::lock_guard lock(mutex);
      for (auto it = pending.begin(); it != pending.end();) {
        if (it->second->space == space) {
          failed.push_back(it->second);
          it = pending.erase(it);
        } else {
          ++it;
        }
      }
    }
    for (auto& call : failed) {
      call->promise.set_value(
          call::Reply::error(call::Status::PROVIDER_GONE, "the bridge of space " + space + " left during the call"));
    }
  }

  // ---- reading ----

  // The listeners run on DDS threads from the moment each reader exists, while the constructor is
  // still assigning the endpoint members: they know a reader by its topic, never by those members.
  static const std::string& topic_of(fdds::DataReader* reader) { return reader->get_topicdescription()->get_name(); }

  void on_data_available(fdds::DataReader* reader) override {
    const OnListener on_listener;
    const std::string& name = topic_of(reader);
    if (name == kCatalogTopic || name == kInterfaceTopic) {
      on_catalog();  // the entries stay in the readers' caches: catalog() reads them
    } else if (name == request_name) {
      read_requests(reader);
    } else if (name == reply_name) {
      read_replies(reader);
    }
  }

  void writer_state(const fdds::InstanceHandle_t& writer, bool alive) {
    std::string lost;  // a space none of whose catalog writers is alive any more
    {
      std::lock_guard lock(catalog_mutex);
      if (alive) {
        dead_writers.erase(writer);
      } else {
        dead_writers.insert(writer);
        auto it = writer_spaces.find(writer);
        if (it != writer_spaces.end()) {
          lost = it->second;
          for (const auto& [other, space] : writer_spaces) {
            if (space == lost && !dead_writers.count(other)) lost.clear();
          }
        }
      }
    }
    // Calls to a space whose bridges are all lost fail now, not when the participant lease ends.
    if (!lost.empty()) fail_pending(lost);
    on_catalog();
  }

  void on_subscription_matched(fdds::DataReader* reader, const fdds::SubscriptionMatchedStatus& status) override {
    if (topic_of(reader) != kCatalogTopic) return;
    if (status.current_count_change != 0) writer_state(status.last_publication_handle, status.current_count_change > 0);
    if (status.current_count_change < 0) {
      std::lock_guard lock(catalog_mutex);
      writer_spaces.erase(status.last_publication_handle);
    }
  }
  void on_liveliness_changed(fdds::DataReader* reader, const fdds::LivelinessChangedStatus& status) override {
    if (topic_of(reader) != kCatalogTopic) return;
    if (status.not_alive_count_change > 0) writer_state(status.last_publication_handle, false);
    if (status.alive_count_change > 0) writer_state(status.last_publication_handle, true);
  }

  // True if `request` was sent longer ago than its deadline (by its writer's clock, which the
  // sites keep in step): its caller has given up, whoever delivers it now.
  static bool stale(const dds::CallRequest& request, const fdds::SampleInfo& info) {
    const auto& sent = info.source_timestamp;
    if (sent == eprosima::fastrtps::rtps::c_RTPSTimeInvalid || sent.seconds() <= 0) return false;
    const auto sent_at = std::chrono::system_clock::time_point(std::chrono::duration_cast<std::chrono::system_clock::duration>(
        std::chrono::seconds(sent.seconds()) + std::chrono::nanoseconds(sent.nanosec())));
    const auto deadline =
        request.deadline_ms() == 0 ? kDefaultDeadline : std::chrono::milliseconds(request.deadline_ms());
    return std::chrono::system_clock::now() - sent_at > deadline;
  }
  // True the first time `id` arrives (within `until`), false for a second delivery.
  bool first_delivery(const std::string& id, Clock::time_point until) {
    std::lock_guard lock(executed_mutex);
    const auto now = Clock::now();
    while (!executed_order.empty() &&
           (executed_order.front().first <= now || executed_order.size() >= kRememberedRequests)) {
      auto it = executed.find(executed_order.front().second);
      if (it != executed.end() && it->second == executed_order.front().first) executed.erase(it);
      executed_order.pop_front();
    }
    if (!executed.emplace(id, until).second) return false;
    executed_order.emplace_back(until, id);
    return true;
  }

  // The caller of the request on `instance` no longer waits for it: its reply is retired.
  void caller_done(const fdds::InstanceHandle_t& instance) {
    std::string id;
    {
      std::lock_guard lock(executed_mutex);
      auto it = serving.find(instance);
      if (it == serving.end()) return;
      id = it->second.first;
      serving.erase(it);
    }
    std::lock_guard lock(mutex);
    for (auto it = registered.begin(); it != registered.end(); ++it) {
      if (it->reply && it->request_id == id) {
        retire(it->writer, id, true);
        registered.erase(it);
        return;
      }
    }
  }
  void serve(const fdds::InstanceHandle_t& instance, const std::string& id, Clock::time_point until) {
    std::lock_guard lock(executed_mutex);
    if (serving.size() >= static_cast<std::size_t>(kRpcInFlight)) {
      const auto now = Clock::now();
      for (auto it = serving.begin(); it != serving.end();) it = it->second.second <= now ? serving.erase(it) : ++it;
    }
    serving[instance] = {id, until};
  }

  void read_requests(fdds::DataReader* reader) {
    dds::CallRequest sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) {  // a request its caller no longer waits for
        caller_done(info.instance_handle);
        continue;
      }
      if (stale(sample, info)) {
        spdlog::info("dds: request {} from space {} arrived after its deadline; not executed", sample.request_id(),
                     sample.caller_space());
        continue;
      }
      const std::string& id = sample.request_id();
      const auto arrived = Clock::now();
      const auto until =
          arrived + (sample.deadline_ms() == 0 ? kDefaultDeadline : std::chrono::milliseconds(sample.deadline_ms()));
      if (!first_delivery(id, until)) {
        spdlog::debug("dds: request {} delivered again; executed once already", id);
        continue;
      }
      call::Request request;
      request.service = sample.service();
      request.operation = sample.operation();
      request.payload = text_of(sample.payload());
      if (sample.deadline_ms() != 0) request.deadline = arrived + std::chrono::milliseconds(sample.deadline_ms());
      request.caller = identities.caller(info.publication_handle, sample.caller_space());
      request.oneway = sample.no_reply();
      call::Responder responder;
      if (!request.oneway) {
        serve(info.instance_handle, id, until);
        responder = responder_for(request.caller.space, id, until);
      }
      on_call(std::move(request), std::move(responder));
    }
  }

  // Answers a call of `space` through the link while it exists: off this link's listener threads
  // at once, on one of them through the replier thread (see CallHandler).
  call::Responder responder_for(const std::string& space, const std::string& id, Clock::time_point until) {
    std::weak_ptr<Impl> link = weak_from_this();
    return call::Responder::from_callback([link, space, id, until](call::Reply reply) {
      auto d = link.lock();
      if (!d) return;  // the link is gone: nobody to write the reply
      if (!on_listener_thread) {
        d->reply_if_open(space, id, reply, until);
        return;
      }
      d->replier.post([link, space, id, reply = std::move(reply), until](bool cancelled) {
        if (cancelled) return;  // the link is stopping
        if (auto d = link.lock()) d->reply_if_open(space, id, reply, until);
      });
    });
  }

  // The reply is written unless the link is stopping (its writers may be deleted then).
  void reply_if_open(const std::string& space, const std::string& id, const call::Reply& reply,
                     Clock::time_point until) {
    const InProgress in_progress(*this);
    if (in_progress.admitted()) send_reply(space, id, reply, until);
  }

  void send_reply(const std::string& space, const std::string& id, const call::Reply& result,
                  Clock::time_point until) {
    // Written at once, matched reader or not: the caller's reply reader, if it matches this
    // writer later, still gets the reply while it is registered (until the caller's deadline).
    std::unique_lock lock(mutex);
    fdds::DataWriter* writer = nullptr;
    try {
      writer = reply_writer(space);
    } catch (const std::exception& e) {
      spdlog::error("dds: reply to {} for {}: {}", space, id, e.what());
      return;
    }
    retire_later(writer, id, true, until);
    lock.unlock();
    dds::CallReply reply;
    reply.request_id(id);
    reply.status(call::status_number(result.status));
    reply.message(result.message);
    reply.exception_type(result.exception_type);
    reply.payload(bytes_of(result.payload));
    if (!writer->write(&reply)) spdlog::warn("dds: the reply to {} could not be written", id);
  }

  void read_replies(fdds::DataReader* reader) {
    dds::CallReply sample;
    fdds::SampleInfo info;
    while (reader->take_next_sample(&sample, &info) == ReturnCode_t::RETCODE_OK) {
      if (!info.valid_data) continue;
      std::shared_ptr<Pending> call;
      {
        std::lock_guard lock(mutex);
        auto it = pending.find(sample.request_id());
        if (it == pending.end()) continue;  // its caller gave up
        call = it->second;
        pending.erase(it);
      }
      call::Reply result;
      const auto status = call::status_from_number(sample.status());
      result.status = status.value_or(call::Status::INTERNAL);
      result.message = status ? sample.message()
                              : "space " + call->space + " answered with status " + std::to_string(sample.status()) +
                                    ", which this bridge does not know: " + sample.message();
      result.exception_type = sample.exception_type();
      result.payload = text_of(sample.payload());
      call->promise.set_value(std::move(result));
    }
  }
};

thread_local bool DdsLink::Impl::on_listener_thread = false;

// Discovery through a Fast DDS discovery server: this participant is the server, or a client of
// the servers given (their GUID prefixes are Fast DDS's defaults for their ids).
void DdsLink::use_discovery_server(fdds::DomainParticipantQos& qos) const {
  auto& discovery = qos.wire_protocol().builtin.discovery_config;
  auto one_locator = [](const std::string& address) {
    if (address.rfind(':') == std::string::npos) {
      throw std::runtime_error("DDS discovery server '" + address + "': HOST:PORT expected");
    }
    return peer_locators(address, 0).front();
  };
  if (!options_.discovery_listen.empty()) {
    discovery.discoveryProtocol = rtps::DiscoveryProtocol_t::SERVER;
    if (!rtps::get_server_client_default_guidPrefix(static_cast<int>(options_.discovery_server_id),
                                                    qos.wire_protocol().prefix)) {
      throw std::runtime_error("DDS discovery server id " + std::to_string(options_.discovery_server_id) +
                               " is out of range");
    }
    qos.wire_protocol().builtin.metatrafficUnicastLocatorList.push_back(one_locator(options_.discovery_listen));
  }
  if (!options_.discovery_servers.empty() && options_.discovery_listen.empty()) {
    discovery.discoveryProtocol = rtps::DiscoveryProtocol_t::CLIENT;
  }
  for (std::size_t id = 0; id < options_.discovery_servers.size(); ++id) {
    eprosima::fastdds::rtps::RemoteServerAttributes server;
    if (!rtps::get_server_client_default_guidPrefix(static_cast<int>(id), server.guidPrefix)) {
      throw std::runtime_error("DDS: at most " + std::to_string(id) + " discovery servers");
    }
    server.metatrafficUnicastLocatorList.push_back(one_locator(options_.discovery_servers[id]));
    discovery.m_DiscoveryServers.push_back(server);
  }
}

DdsLink::DdsLink(DdsOptions options, CatalogHandler on_catalog, CallHandler on_call)
    : options_(std::move(options)), impl_(std::make_shared<Impl>(options_, std::move(on_catalog), std::move(on_call))) {
  auto* factory = fdds::DomainParticipantFactory::get_instance();
  factory->load_profiles();  // an XML default profile's settings, but for the transports set below
  fdds::DomainParticipantQos qos = factory->get_default_participant_qos();
  qos.name("urs-bridge/" + options_.space + "/" + options_.bridge);
  // A participant that stops announcing itself (dead process, cut network) is dropped after its
  // lease; its entries end earlier, with its writers' liveliness (`lease`). Announced four times
  // a `lease`, so that a peer that dropped it finds it again quickly.
  qos.wire_protocol().builtin.discovery_config.leaseDuration =
      link_qos::duration(std::max(options_.participant_lease, options_.lease));
  qos.wire_protocol().builtin.discovery_config.leaseDuration_announcementperiod =
      link_qos::duration(options_.lease / 4);
  qos.transport().use_builtin_transports = false;
  auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
  udp->sendBufferSize = options_.socket_buffer_bytes;
  udp->receiveBufferSize = options_.socket_buffer_bytes;
  qos.transport().user_transports.push_back(udp);
  if (!options_.udp_only) {
    auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
    shm->segment_size(options_.shm_segment_bytes);
    qos.transport().user_transports.push_back(shm);
  }
  qos.transport().send_socket_buffer_size = options_.socket_buffer_bytes;
  qos.transport().listen_socket_buffer_size = options_.socket_buffer_bytes;
  for (const auto& peer : options_.initial_peers) {
    for (const auto& locator : peer_locators(peer, options_.domain)) {
      qos.wire_protocol().builtin.initialPeersList.push_back(locator);
    }
  }
  use_discovery_server(qos);
  if (options_.security.enabled()) {
    // Checked here: Fast DDS would say only "initialization error" for any bad file.
    const std::vector<std::string> problems = check_dds_security(options_.security, options_.space);
    if (!problems.empty()) {
      std::string text;
      for (const auto& problem : problems) text += "\n  " + problem;
      throw std::runtime_error("DDS security: cannot join domain " + std::to_string(options_.domain) + ":" + text);
    }
    for (const auto& [name, value] : dds_security_properties(options_.security)) {
      qos.properties().properties().emplace_back(name, value);
    }
  }
  Impl& d = *impl_;
  d.participant = factory->create_participant(options_.domain, qos, &d.identities, fdds::StatusMask::none());
  if (d.participant == nullptr) {
    throw std::runtime_error("DDS: cannot join domain " + std::to_string(options_.domain) +
                             (options_.security.enabled() ? " with DDS security (see Fast DDS's log above)" : ""));
  }
  try {
    d.publisher = d.participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    d.subscriber = d.participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
    if (d.publisher == nullptr || d.subscriber == nullptr) throw std::runtime_error("DDS: cannot create a publisher");
    for (auto* type : {&d.entry_type, &d.interface_type, &d.request_type, &d.reply_type}) {
      if (type->register_type(d.participant) != ReturnCode_t::RETCODE_OK) {
        throw std::runtime_error("DDS: cannot register type " + type->get_type_name());
      }
    }
    d.catalog_topic = d.topic(kCatalogTopic, d.entry_type);

    const fdds::DataWriterQos catalog_writer = link_qos::keyed_state_writer(options_.lease);
    d.catalog_writer = d.publisher->create_datawriter(d.catalog_topic, catalog_writer);
    // Descriptions: the same QoS, one instance per description. Fast DDS keeps two copies of each
    // sample a writer holds, so a description per service cost ~30 KiB per service.
    d.interface_writer =
        d.publisher->create_datawriter(d.topic(kInterfaceTopic, d.interface_type), catalog_writer);

    // Entries end by a dispose and an unregistration (withdraw()); descriptions never do.
    d.catalog_reader =
        d.subscriber->create_datareader(d.catalog_topic, link_qos::ending_state_reader(options_.lease), &d);
    d.interface_reader = d.subscriber->create_datareader(d.topic(kInterfaceTopic, d.interface_type),
                                                         link_qos::keyed_state_reader(options_.lease), &d);

    d.request_reader = d.subscriber->create_datareader(d.topic(request_topic(options_.space), d.request_type),
                                                       d.rpc_reader_qos(), &d);
    d.reply_reader = d.subscriber->create_datareader(d.topic(reply_topic(options_.space), d.reply_type),
                                                     d.rpc_reader_qos(), &d);
    if (!d.catalog_writer || !d.catalog_reader || !d.interface_writer || !d.interface_reader || !d.request_reader ||
        !d.reply_reader) {
      throw std::runtime_error("DDS: cannot create the catalog and call endpoints");
    }
    d.asserter = std::make_unique<LivelinessAsserter>(std::max(std::chrono::milliseconds(1), options_.lease / 4));
    d.asserter->add(d.catalog_writer);
    d.asserter->add(d.interface_writer);
  } catch (...) {
    d.asserter.reset();
    d.participant->delete_contained_entities();
    factory->delete_participant(d.participant);
    throw;
  }
}

DdsLink::~DdsLink() {
  Impl& d = *impl_;
  // Calls in progress end first (UNAVAILABLE "bridge stopping"), while their writers still exist:
  // no new call is admitted, those waiting for a match are woken, those waiting for a reply failed.
  {
    std::lock_guard lock(d.calls_mutex);
    d.closing = true;
  }
  std::vector<std::shared_ptr<Impl::Pending>> left;
  {
    std::lock_guard lock(d.mutex);  // a call registers its pending reply under it, closing or not
    for (auto& listener : d.writer_listeners) listener->wake();
    for (auto& [id, call] : d.pending) left.push_back(call);
    d.pending.clear();
  }
  for (auto& call : left) call->promise.set_value(call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping"));
  d.replier.stop();  // a reply it writes now is refused (closing); those queued are dropped
  {
    std::unique_lock lock(d.calls_mutex);
    d.calls_done.wait(lock, [&] { return d.calls_in_progress == 0; });
  }
  d.asserter.reset();
  d.participant->set_listener(nullptr);
  d.participant->delete_contained_entities();
  fdds::DomainParticipantFactory::get_instance()->delete_participant(d.participant);
}

fdds::DomainParticipant* DdsLink::participant() const { return impl_->participant; }

void DdsLink::keep_alive(fdds::DataWriter* writer) { impl_->asserter->add(writer); }

void DdsLink::let_go(fdds::DataWriter* writer) { impl_->asserter->remove(writer); }

std::vector<ServiceEntry> DdsLink::catalog() const {
  Impl& d = *impl_;
  std::set<fdds::InstanceHandle_t> dead;
  {
    std::lock_guard lock(d.catalog_mutex);
    dead = d.dead_writers;
  }
  std::vector<ServiceEntry> entries;
  // The descriptions known now (an entry whose description has not arrived yet is left out until
  // it has: its arrival wakes the bridge again).
  std::map<std::string, std::string> descriptions;
  fdds::LoanableSequence<dds::InterfaceDescription> described;
  fdds::SampleInfoSeq described_infos;
  // Any instance state: a description is its digest's content whoever wrote it and whether or
  // not its writer is alive (the entries' liveliness is the catalog's).
  if (d.interface_reader->read(described, described_infos, fdds::LENGTH_UNLIMITED, fdds::ANY_SAMPLE_STATE,
                               fdds::ANY_VIEW_STATE, fdds::ANY_INSTANCE_STATE) == ReturnCode_t::RETCODE_OK) {
    for (fdds::LoanableCollection::size_type i = 0; i < described.length(); ++i) {
      if (described_infos[i].valid_data) descriptions[described[i].digest()] = text_of(described[i].descriptor_set());
    }
    d.interface_reader->return_loan(described, described_infos);
  }
  fdds::LoanableSequence<dds::ServiceEntry> samples;
  fdds::SampleInfoSeq infos;
  if (d.catalog_reader->read(samples, infos, fdds::LENGTH_UNLIMITED, fdds::ANY_SAMPLE_STATE, fdds::ANY_VIEW_STATE,
                             fdds::ALIVE_INSTANCE_STATE) != ReturnCode_t::RETCODE_OK) {
    return entries;
  }
  std::map<fdds::InstanceHandle_t, std::string> spaces;
  for (fdds::LoanableCollection::size_type i = 0; i < samples.length(); ++i) {
    if (infos[i].valid_data) spaces[infos[i].publication_handle] = samples[i].space();
    if (!infos[i].valid_data || dead.count(infos[i].publication_handle)) continue;
    const dds::ServiceEntry& sample = samples[i];
    if (sample.space() == options_.space) continue;  // our own entries
    const auto description = descriptions.find(sample.interface_digest());
    if (description == descriptions.end()) continue;
    entries.push_back({sample.space(), sample.name(), sample.interface_name(), sample.repository_id(), sample.origin(),
                       sample.bridge(), sample.deadline_ms(), description->second});
  }
  d.catalog_reader->return_loan(samples, infos);
  {
    std::lock_guard lock(d.catalog_mutex);
    for (auto& [writer, space] : spaces) d.writer_spaces[writer] = std::move(space);
  }
  return entries;
}

void DdsLink::announce(const ServiceEntry& entry) {
  dds::ServiceEntry sample;
  sample.space(options_.space);
  sample.name(entry.name);
  sample.interface_name(entry.interface_name);
  sample.repository_id(entry.repository_id);
  sample.origin(entry.origin);
  sample.bridge(options_.bridge);
  sample.deadline_ms(entry.deadline_ms);
  sample.interface_digest(digest_of(entry.descriptor_set));
  {
    // Each description before the first entry naming it (readers skip entries whose description
    // they lack, so the order only saves a wake-up), and again once a lease with the entries'
    // re-announcement: a reader that lost this writer (a cut network) and matches it again would
    // drop the samples it had already seen, so only new ones reach it.
    std::lock_guard lock(impl_->interfaces_mutex);
    const auto now = Clock::now();
    auto [written, first] = impl_->interfaces_written.try_emplace(sample.interface_digest(), now);
    if (first || now - written->second >= options_.lease) {
      written->second = now;
      dds::InterfaceDescription description;
      description.digest(sample.interface_digest());
      description.descriptor_set(bytes_of(entry.descriptor_set));
      if (!impl_->interface_writer->write(&description)) {
        spdlog::warn("dds: the description of {} could not be written", entry.interface_name);
        impl_->interfaces_written.erase(sample.interface_digest());
      }
    }
  }
  if (!impl_->catalog_writer->write(&sample)) spdlog::warn("dds: announcing {} failed", entry.name);
}

void DdsLink::withdraw(const std::string& name) {
  dds::ServiceEntry sample;
  sample.space(options_.space);
  sample.name(name);
  // By key (HANDLE_NIL): Fast DDS 2.9's lookup_instance() finds no instance that write() made, so
  // a withdrawal looked up first was never sent. An entry never announced is refused, harmlessly.
  impl_->catalog_writer->dispose(&sample, fdds::HANDLE_NIL);
  impl_->catalog_writer->unregister_instance(&sample, fdds::HANDLE_NIL);
}

call::Reply DdsLink::call(const std::string& space, const std::string& service, const std::string& operation,
                          std::string payload, std::chrono::milliseconds deadline) {
  Impl& d = *impl_;
  const Impl::InProgress in_progress(d);  // first: the last to end
  if (!in_progress.admitted()) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
  if (d.space_lost(space)) {
    return call::Reply::error(call::Status::UNAVAILABLE, "the bridge of space " + space + " lost its liveliness");
  }
  const auto until = Clock::now() + deadline;
  const std::string id = d.next_request_id();
  auto pending = std::make_shared<Impl::Pending>();
  pending->space = space;
  auto answer = pending->promise.get_future();
  Impl::RequestRoute route;
  try {
    std::lock_guard lock(d.mutex);
    if (d.closing) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
    route = d.request_writer(space);
    d.pending[id] = pending;
  } catch (const std::exception& e) {
    if (options_.security.enabled()) {  // on a secured link, the access control refused the writer
      return call::Reply::error(call::Status::PERMISSION_DENIED, "the permissions of space " + options_.space +
                                                                     " do not grant calls to space " + space);
    }
    return call::Reply::error(call::Status::UNAVAILABLE, e.what());
  }
  fdds::DataWriter* writer = route.writer;
  auto forget = [&] {
    std::lock_guard lock(d.mutex);
    d.pending.erase(id);
  };
  // A writer made for this call waits for discovery; a known space's is matched already.
  if (!route.listener->wait_matched(std::min(until, Clock::now() + kMatchWait))) {
    forget();
    if (d.closing) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
    return call::Reply::error(call::Status::UNAVAILABLE, "space " + space + " is not reachable over DDS (no bridge of it matched)");
  }
  dds::CallRequest request;
  request.request_id(id);
  request.caller_space(options_.space);
  request.service(service);
  request.operation(operation);
  request.deadline_ms(static_cast<uint32_t>(
      std::max<int64_t>(1, std::chrono::duration_cast<std::chrono::milliseconds>(until - Clock::now()).count())));
  request.no_reply(false);
  request.payload(bytes_of(payload));
  if (!writer->write(&request)) {
    forget();
    return call::Reply::error(call::Status::UNAVAILABLE, "the request to space " + space + " could not be written");
  }
  // Whatever the outcome, nobody waits for this request any more: a replier matching later must
  // not execute it, and the one that did may forget its reply.
  const bool answered = answer.wait_until(until) == std::future_status::ready;
  Impl::retire(writer, id, false);
  if (!answered) {
    forget();
    return call::Reply::error(call::Status::DEADLINE_EXCEEDED, "no reply from space " + space + " for " + service +
                                                                    "." + operation + " within " +
                                                                    std::to_string(deadline.count()) + " ms");
  }
  return answer.get();
}

bool DdsLink::oneway(const std::string& space, const std::string& service, const std::string& operation,
                     std::string payload) {
  Impl& d = *impl_;
  const Impl::InProgress in_progress(d);  // first: the last to end
  if (!in_progress.admitted() || d.space_lost(space)) return false;
  Impl::RequestRoute route;
  try {
    std::lock_guard lock(d.mutex);
    if (d.closing) return false;
    route = d.request_writer(space);
  } catch (const std::exception&) {
    return false;
  }
  if (!route.listener->wait_matched(Clock::now() + kMatchWait)) return false;
  fdds::DataWriter* writer = route.writer;
  dds::CallRequest request;
  request.request_id(d.next_request_id());
  request.caller_space(options_.space);
  request.service(service);
  request.operation(operation);
  request.no_reply(true);
  request.payload(bytes_of(payload));
  if (!writer->write(&request)) return false;
  // No reply tells when it was served: it stays available to a replier matching late for as long
  // as a replier would take it (kDefaultDeadline), then is retired.
  std::lock_guard lock(d.mutex);
  d.retire_later(writer, request.request_id(), false, Clock::now() + kDefaultDeadline);
  return true;
}

}  // namespace urs::bridge
