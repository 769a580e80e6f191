// DdsLink: the façade over the link's components, each in its own file: the participant
// (dds_participant), the catalog (dds_catalog), the calling side (dds_calls) and the serving side
// (dds_served), with what the two sides share (dds_rpc.hpp, call_gate.hpp, rpc_registrations).
// Impl is the one listener of every reader of the link and hands each event to its component.

#include "urs/federation/dds_link.hpp"

#include <algorithm>
#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/topic/TopicDescription.hpp>
#include <map>
#include <mutex>
#include <optional>

#include "call_gate.hpp"
#include "dds_calls.hpp"
#include "dds_catalog.hpp"
#include "dds_participant.hpp"
#include "dds_served.hpp"
#include "liveliness_asserter.hpp"
#include "rpc_registrations.hpp"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;

std::string caller_name_problem(const std::string& name) {
  if (name.empty()) return "is empty";
  if (name.size() > kMaxCallerName) {
    return "is " + std::to_string(name.size()) + " bytes long (at most " + std::to_string(kMaxCallerName) + ")";
  }
  if (std::any_of(name.begin(), name.end(), [](unsigned char c) { return c <= 0x20 || c > 0x7e; })) {
    return "holds white space or a character outside printable ASCII";
  }
  if (name.rfind("dds:", 0) == 0) return "'" + name + "' begins with 'dds:' (the bridges' own names)";
  return "";
}

struct DdsLink::Impl : public fdds::DataReaderListener {
  Impl(const DdsOptions& options, CatalogHandler on_catalog, CallHandler on_call)
      : identities(options.security.enabled(), [this] { catalog.proven(); }),
        catalog(options, participant, identities, std::move(on_catalog),
                [this](const std::string& space) { calls.fail_pending(space); }),
        calls(options, participant, gate, registrations, identities),
        served(options, participant, gate, registrations, identities, std::move(on_call)) {}

  LinkParticipant participant;
  // Calls in progress (call(), oneway(), replies): the destructor closes it, wakes them and waits
  // until none is left, before it deletes what they use.
  CallGate gate;
  RpcRegistrations registrations;  // requests and replies still registered
  // The space each remote participant proved (told by the participant): the callers of requests,
  // and whose catalog entries and state samples are taken. A space proven anew re-reads the catalog.
  DdsIdentities identities;
  DdsCatalog catalog;
  DdsCalls calls;
  DdsServed served;
  // Asserts the keyed-state writers' liveliness (the link's and StateLink's); stopped first.
  std::unique_ptr<LivelinessAsserter> asserter;

  // Samples lost by the link's readers and StateLink's, by topic.
  std::mutex lost_mutex;
  std::map<std::string, uint64_t> lost;

  // Why a call to `space` is refused at once, if it is: the link is closing, or the space lost
  // (counted).
  std::optional<call::Reply> refusal(const CallGate::InProgress& in_progress, const std::string& space) {
    if (!in_progress.admitted()) return call::Reply::error(call::Status::UNAVAILABLE, "bridge stopping");
    if (catalog.space_lost(space)) {
      call::Reply lost_space =
          call::Reply::error(call::Status::UNAVAILABLE, "the bridge of space " + space + " lost its liveliness");
      calls.count_failure(space, lost_space);
      return lost_space;
    }
    return std::nullopt;
  }

  void count_lost(const std::string& topic, uint64_t count) {
    std::lock_guard lock(lost_mutex);
    // The link's own topics and StateLink's: a few, named by the code.
    lost[topic] += count;
  }

  // The listeners run on DDS threads from the moment each reader exists, while the constructor is
  // still creating the others: they know a reader by its topic, never by its component's members.
  static const std::string& topic_of(fdds::DataReader* reader) { return reader->get_topicdescription()->get_name(); }

  void on_data_available(fdds::DataReader* reader) override {
    const DdsServed::OnListener on_listener;
    const std::string& name = topic_of(reader);
    if (name == DdsCatalog::kCatalogTopic || name == DdsCatalog::kInterfaceTopic) {
      catalog.changed();  // the entries stay in the readers' caches: catalog() reads them
    } else if (name == served.request_name()) {
      served.read_requests(reader);
    } else if (name == calls.reply_name()) {
      calls.read_replies(reader);
    }
  }
  void on_subscription_matched(fdds::DataReader* reader, const fdds::SubscriptionMatchedStatus& status) override {
    if (topic_of(reader) == DdsCatalog::kCatalogTopic) catalog.subscription_matched(status);
  }
  void on_liveliness_changed(fdds::DataReader* reader, const fdds::LivelinessChangedStatus& status) override {
    if (topic_of(reader) == DdsCatalog::kCatalogTopic) catalog.liveliness_changed(status);
  }
  void on_sample_lost(fdds::DataReader* reader, const fdds::SampleLostStatus& status) override {
    if (status.total_count_change > 0) count_lost(topic_of(reader), static_cast<uint64_t>(status.total_count_change));
  }
};

DdsLink::DdsLink(DdsOptions options, CatalogHandler on_catalog, CallHandler on_call)
    : options_(std::move(options)), impl_(std::make_shared<Impl>(options_, std::move(on_catalog), std::move(on_call))) {
  Impl& d = *impl_;
  d.participant.join(options_, &d.identities);
  try {
    d.catalog.open(&d);
    // The responders share the link's ownership, weakly.
    d.served.open(std::shared_ptr<DdsServed>(impl_, &d.served), &d);
    d.calls.open(&d);
    d.asserter = std::make_unique<LivelinessAsserter>(std::max(std::chrono::milliseconds(1), options_.lease / 4));
    for (fdds::DataWriter* writer : d.catalog.writers()) d.asserter->add(writer);
  } catch (...) {
    d.asserter.reset();
    d.participant.leave();
    throw;
  }
}

DdsLink::~DdsLink() {
  Impl& d = *impl_;
  // Calls in progress end first (UNAVAILABLE "bridge stopping"), while their writers still exist:
  // no new call is admitted, those waiting for a match are woken, those waiting for a reply failed.
  d.gate.close();
  d.calls.close();
  d.served.stop();  // a reply it writes now is refused (closing); those queued are dropped
  d.gate.wait_idle();
  d.asserter.reset();
  d.participant.leave();
}

fdds::DomainParticipant* DdsLink::participant() const { return impl_->participant.participant(); }

std::optional<std::chrono::steady_clock::time_point> DdsLink::lost_since(const std::string& space) const {
  return impl_->catalog.lost_since(space);
}

std::optional<std::chrono::system_clock::time_point> DdsLink::reached_since(const std::string& space) const {
  return impl_->catalog.reached_since(space);
}

bool DdsLink::speaks_for(const fdds::SampleInfo& info, const std::string& space, const char* kind,
                         const std::string& name) const {
  return impl_->identities.speaks_for(info.publication_handle, space, kind, name);
}

void DdsLink::keep_alive(fdds::DataWriter* writer) { impl_->asserter->add(writer); }

void DdsLink::let_go(fdds::DataWriter* writer) { impl_->asserter->remove(writer); }

std::vector<ServiceEntry> DdsLink::catalog() const { return impl_->catalog.entries(); }

uint64_t DdsLink::catalog_writers_matched() const { return impl_->catalog.writers_matched(); }

std::map<std::string, SpaceCalls> DdsLink::space_calls() const { return impl_->calls.space_calls(); }

std::map<std::string, SpaceServed> DdsLink::space_served() const { return impl_->served.space_served(); }

void DdsLink::count_failure(const std::string& space, const call::Reply& reply) {
  impl_->calls.count_failure(space, reply);
}

std::map<std::string, uint64_t> DdsLink::samples_lost() const {
  std::lock_guard lock(impl_->lost_mutex);
  return impl_->lost;
}

void DdsLink::count_samples_lost(const std::string& topic, uint64_t count) { impl_->count_lost(topic, count); }

void DdsLink::announce(const ServiceEntry& entry) { impl_->catalog.announce(entry); }

void DdsLink::withdraw(const std::string& name) { impl_->catalog.withdraw(name); }

call::Reply DdsLink::call(const std::string& space, const std::string& service, const std::string& operation,
                          std::string payload, std::chrono::milliseconds deadline, const std::string& caller) {
  Impl& d = *impl_;
  const CallGate::InProgress in_progress(d.gate);  // first: the last to end
  if (auto refused = d.refusal(in_progress, space)) return std::move(*refused);
  return d.calls.call(space, service, operation, std::move(payload), deadline, caller);
}

bool DdsLink::oneway(const std::string& space, const std::string& service, const std::string& operation,
                     std::string payload, const std::string& caller) {
  Impl& d = *impl_;
  const CallGate::InProgress in_progress(d.gate);  // first: the last to end
  if (d.refusal(in_progress, space)) return false;
  return d.calls.oneway(space, service, operation, std::move(payload), caller);
}

bool DdsLink::call_async(const std::string& space, const std::string& service, const std::string& operation,
                         std::string&& payload, std::chrono::milliseconds deadline, const std::string& caller,
                         std::function<void(call::Reply)> done) {
  Impl& d = *impl_;
  const CallGate::InProgress in_progress(d.gate);  // until its request is written: close() ends it after
  if (auto refused = d.refusal(in_progress, space)) {
    done(std::move(*refused));
    return true;
  }
  return d.calls.call_async(space, service, operation, std::move(payload), deadline, caller, std::move(done));
}

std::optional<bool> DdsLink::oneway_async(const std::string& space, const std::string& service,
                                          const std::string& operation, std::string&& payload,
                                          const std::string& caller) {
  Impl& d = *impl_;
  const CallGate::InProgress in_progress(d.gate);  // first: the last to end
  if (d.refusal(in_progress, space)) return false;
  return d.calls.oneway_async(space, service, operation, std::move(payload), caller);
}

}  // namespace urs::federation
