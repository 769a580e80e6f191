#pragma once
// RtSide: the bridge's RT side (docs/bridge.md "RT side"): the bridge's own RT-Component (bound as
// <host>.host_cxt/<instance>.rtc), whose lifecycle drives the bridge (activated: active), and a
// watch of the naming service as a connector does: the components the configuration concerns are
// read, probed and their ports connected to the bridge RTC's ("providers", in<N>, out<N>).
//
//   ServiceSource    the provider interfaces connected to "providers" (whoever connected them: the
//                    watch, `urs rtc con`, rtcon) whose IDL the bridge knows, as offers (key
//                    "<connector id>|<published key>", name the provider's naming path, fields
//                    {instance} {port} {interface} {host}, properties rtc.type_name,
//                    urslink.health, rtc.state, source "rtc:<path>:<port>"); a call to one is a
//                    DII request (corba_agent::CorbaProxyAgent)
//   ServiceOffering  a stand-in is an RT-Component (corba_agent::AgentComponent, instance name the
//                    route's with characters other than [A-Za-z0-9_-] made '_', type the source's
//                    kind()) with one provider port of the service's interface and the component
//                    properties urslink.origin=<offer source>, urslink.bridge=<bridge> and the offer's
//   StateSource      every RTC's lifecycle state (components of kind "rtc"), every state_period
//   StreamSource     values arriving at in<N> (from the OutPorts of in[N]), as stream entry N
//   StreamSink       stream entry N written through out<N> (to the InPorts of out[N]), one value at
//                    a time in order, off the caller's thread
//
// The connections of the bridge's RTCs are kept in `connections_file` and made again after a
// restart (ConnectionStore, docs/bridge.md "Restarts").
//
// Threads: the control methods on the bridge's thread; stream values arrive on the RT ports'
// threads. Lives as long as the bridge (the RTC across its activations).

#include <chrono>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "urs/agent/agent.hpp"
#include "urs/bridge/core/side.hpp"
#include "urs/rtc/manager.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/schema/interface_catalog.hpp"

namespace urs::bridge {

class BridgeComponent;
class ConnectionKeeper;
class RtStandIns;
class RtWatch;

// A data port of the components `match` concerns, connected to one of the bridge RTC's own.
struct DataPortRule {
  std::string match;  // glob on naming paths
  std::string port;   // the component's port
  std::string type;   // the values' type (Protobuf full name of an IDL struct)
};

// Provider ports of the components `match` concerns, of an interface `interface` matches, that
// the watch connects to the bridge RTC's "providers".
struct ProviderMatch {
  std::string match = "*";      // glob on naming paths
  std::string interface = "*";  // glob on the provided interface's type_name
};

struct RtSideConfig {
  std::string bridge;                            // the bridge's name: urslink.bridge of its RTCs, its connections' name
  std::string instance;                          // the bridge RTC's instance name ("": the manager chooses)
  bool activate = true;                          // activate the bridge RTC at start
  std::string connections_file;                  // "": the connections are not kept
  std::vector<ProviderMatch> providers;          // what the watch connects to "providers"
  std::vector<DataPortRule> in;                  // their OutPorts -> in<N>
  std::vector<DataPortRule> out;                 // out<N> -> their InPorts
  std::chrono::milliseconds poll{200};           // the naming watch's period
  std::chrono::milliseconds state_period{1000};  // how often RTC states are read when shared
};

class RtSide final : public core::Side,
                     public core::ServiceSource,
                     public core::ServiceOffering,
                     public core::StateSource,
                     public core::StreamSource,
                     public core::StreamSink {
 public:
  // All outlive the side. Throws util::ConfigError for a data port type the catalog does not know
  // or that is not an IDL struct, exception or union.
  RtSide(rtc::Orb& orb, rtc::NamingClient& naming, rtc::Manager& manager, const schema::InterfaceCatalog& catalog,
         RtSideConfig config);
  ~RtSide() override;

  // The bridge RTC's naming path (after start()).
  const std::string& path() const { return path_; }

  // core::Side
  // Creates the bridge RTC through the manager and activates it if configured; throws
  // util::Error (the reason) if it cannot.
  void start(core::SideEvents& events) override;
  void stop() override;
  bool drives_activity() const override { return true; }
  void open() override;
  Clock::time_point poll(Clock::time_point now) override;
  core::ServiceSource* services() override { return this; }
  core::ServiceOffering* offering() override { return this; }
  core::StateSource* state_source() override { return this; }
  core::StreamSource* stream_source() override { return this; }
  core::StreamSink* stream_sink() override { return this; }

  // core::ServiceSource
  std::string kind() const override { return "RtProvider"; }
  std::optional<std::vector<core::Offer>> offers() override;
  std::shared_ptr<agent::ServiceAgent> serve(const core::Route& route) override;

  // core::ServiceOffering
  core::OfferOutcome offer(const core::Route& route, core::ServiceSource& from) override;
  void withdraw(const core::Route& route) override;
  std::string usable_name(const std::string& name) const override;

  // core::StateSource
  void share_state(core::StateSink* sink) override;

  // core::StreamSource
  void stream_to(core::StreamSink* sink) override;
  // core::StreamSink
  void write(std::size_t entry, const google::protobuf::Message& value) override;

 private:
  // The RTCs of the bridge whose connections are kept across restarts, by ConnectionStore key.
  std::vector<std::pair<std::string, rtc::Component*>> our_rtcs() const;

  rtc::Orb& orb_;
  rtc::NamingClient& naming_;
  rtc::Manager& manager_;
  const schema::InterfaceCatalog& catalog_;
  const RtSideConfig config_;

  std::mutex events_mutex_;  // the RTC's lifecycle reports through events_ until stop()
  core::SideEvents* events_ = nullptr;

  BridgeComponent* component_ = nullptr;  // owned by the manager
  std::string path_;
  std::unique_ptr<RtWatch> watch_;
  std::unique_ptr<RtStandIns> stand_ins_;
  std::unique_ptr<ConnectionKeeper> connections_;
  core::StateSink* state_sink_ = nullptr;  // the bridge's thread only
  std::chrono::steady_clock::time_point states_read_at_{};

  std::mutex stream_mutex_;  // held while a value is handed to stream_sink_
  core::StreamSink* stream_sink_ = nullptr;
  agent::WorkerPool writer_{1};  // writes to out<N>, in order: a slow InPort never holds up the caller
};

}  // namespace urs::bridge
