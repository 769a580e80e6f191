// urs: the command-line client of a CAMUS space (rtshell-like; docs/camus.md) and, with
// `urs rtc ...`, of the RT side's naming service and components (docs/rtc.md).
//
// Exit codes: 0 success; 1 the call or operation failed (one-line reason on stderr);
// 2 bad usage or arguments; 3 the server (or naming service) cannot be reached.

#include <google/protobuf/util/json_util.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <charconv>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <deque>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <sstream>

#include "camus.pb.h"
#include "dynamic_caller.hpp"
#include "link_command.hpp"
#include "recording_commands.hpp"
#include "rtc_commands.hpp"
#include "urs/planet/authenticator.hpp"
#include "urs/planet/client.hpp"
#include "urs/util/cli.hpp"
#include "urs/util/program_flags.hpp"
#include "urs/util/tls.hpp"
#include "urs/util/trace.hpp"

namespace {

using urs::planet::CallResult;
namespace camus = urs::camus;

constexpr int kOk = 0;
constexpr int kFailed = 1;
constexpr int kUsage = 2;
constexpr int kUnreachable = 3;

std::string env_or(const char* name, const std::string& fallback) {
  const char* value = std::getenv(name);
  return value != nullptr && *value != '\0' ? value : fallback;
}

int report(const std::string& what, const CallResult& result, const std::string& detail_json = {}) {
  std::cerr << "urs: " << what << ": " << urs::planet::status_name(result.status);
  if (!result.exception_type.empty()) std::cerr << " " << result.exception_type;
  if (!detail_json.empty()) std::cerr << " " << detail_json;
  if (!result.message.empty()) std::cerr << ": " << result.message;
  std::cerr << "\n";
  return result.status == urs::planet::UNAVAILABLE ? kUnreachable : kFailed;
}

// How long ago `unix_seconds` (a decimal string) was, as "42s", "7m" or "3h"; "?" if it is not a time.
std::string unreachable_for(const std::string& unix_seconds) {
  int64_t since = 0;
  const auto [end, error] = std::from_chars(unix_seconds.data(), unix_seconds.data() + unix_seconds.size(), since);
  if (error != std::errc() || end != unix_seconds.data() + unix_seconds.size()) return "?";
  return urs::cli::ago(since);
}

std::string to_json(const google::protobuf::Message& message) {
  std::string json;
  urs::schema::message_to_json(message, json);
  return json;
}

// Calls a built-in service with compiled types; prints the reply as JSON on success.
template <class Reply>
int builtin(urs::planet::Client& client, const std::string& service, const std::string& operation,
            const google::protobuf::Message& request, std::chrono::milliseconds timeout, Reply& reply,
            bool print = true) {
  auto result = client.call(service, operation, request.SerializeAsString(), timeout);
  if (!result.ok()) return report(service + "." + operation, result);
  if (!reply.ParseFromString(result.payload)) {
    return report(service + "." + operation,
                  CallResult::error(urs::planet::INTERNAL, "unreadable " + reply.GetTypeName()));
  }
  if (print) std::cout << to_json(reply) << "\n";
  return kOk;
}

std::string read_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw urs::util::ConfigError("cannot read '" + path + "'");
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

}  // namespace

int main(int argc, char** argv) {
  // urs record / urs play: the Python SDK's recorder and player, with every argument theirs.
  if (urs::cli::is_recording_command(argc, argv)) return urs::cli::run_recording_command(argc, argv);
  CLI::App app{"urs: command-line client of a CAMUS space"};
  app.footer("Also: urs record / urs play (a space's gateway recorded to MCAP and played back): urs record --help");
  app.require_subcommand(1);
  std::string server = env_or("URS_SERVER", "127.0.0.1:7600");
  std::string token_file;
  std::string log_level = "warn";
  int timeout_ms = 5000;
  app.add_option("--server", server, "CAMUS server HOST:PORT (env URS_SERVER)")->capture_default_str();
  app.add_option("--token-file", token_file,
                 "File holding this client's credential token (or env URS_TOKEN_FILE, or the token in URS_TOKEN)");
  app.add_option("--timeout-ms", timeout_ms, "Connection and built-in call timeout")->capture_default_str();
  urs::util::TlsConfig tls_config;
  urs::util::add_tls_client_flags(app, tls_config);
  app.add_option("--log-level", log_level, urs::util::kLogLevels)->capture_default_str();
  std::string log_format = "text";
  urs::util::add_log_format_flag(app, log_format);

  auto* ls = app.add_subcommand("ls", "List services (glob PATTERN)");
  std::string pattern;
  bool json_out = false;
  ls->add_option("pattern", pattern, "Glob on service names");
  ls->add_flag("--json", json_out, "Print the registry's JSON reply");

  auto* spaces = app.add_subcommand(
      "spaces", "List the other spaces whose services this space imports: reachable or unreachable (for how long)");
  spaces->add_flag("--json", json_out, "Print the registry's JSON reply");

  auto* link_command = app.add_subcommand(
      "link",
      "Show the link to each other space as one bridge meets it: state and since when, peers, services, round "
      "trips, the link's failures (read from the bridge's --metrics-listen endpoint)");
  std::string link_bridge;
  link_command
      ->add_option("bridge", link_bridge, "The bridge's metrics endpoint HOST:PORT (urs-bridge --metrics-listen)")
      ->required();
  link_command->add_flag("--json", json_out, "Print one JSON object");

  auto* whoami = app.add_subcommand("whoami", "Print who the server takes this client for: identity, role, space");

  auto* describe = app.add_subcommand("describe", "Show the operations of a service's interface");
  std::string service;
  describe->add_option("service", service)->required();

  auto* call = app.add_subcommand("call", "Call SERVICE OPERATION with JSON arguments; print the JSON reply");
  std::string operation;
  std::string args;
  int deadline_ms = 0;
  call->add_option("service", service)->required();
  call->add_option("operation", operation)->required();
  call->add_option("json", args, "Request as JSON (Protobuf JSON mapping); default {}");
  call->add_option("--deadline-ms", deadline_ms,
                   "Deadline of the call (default: none sent, so the service's advertised deadline applies)")
      ->check(CLI::Range(1, std::numeric_limits<int>::max()));
  std::string traceparent;
  call->add_option("--traceparent", traceparent,
                   "Make the call part of this W3C trace (00-<trace id>-<parent id>-<flags>, e.g. from the program "
                   "that runs urs) instead of starting a new one");
  bool show_trace = false;
  call->add_flag("--show-trace", show_trace,
                 "Print the call's trace id on stderr when it succeeds too (always when it fails or stderr is a "
                 "terminal)");

  auto* watch = app.add_subcommand("watch", "Print events whose topic matches PATTERN, one JSON line each");
  int count = 0;
  int for_ms = 0;
  uint64_t resume_after = 0;
  watch->add_option("pattern", pattern)->required();
  watch->add_option("--count", count, "Exit after this many events");
  watch->add_option("--for-ms", for_ms, "Exit after this long");
  watch->add_option("--resume-after", resume_after, "Replay retained events with a larger sequence first");

  auto* pub = app.add_subcommand("pub", "Publish an event on TOPIC: JSON as message TYPE (or as application/json)");
  std::string topic;
  std::string type;
  pub->add_option("topic", topic)->required();
  pub->add_option("json", args, "The event as JSON (Protobuf JSON mapping of TYPE)")->required();
  pub->add_option("--type", type, "Full Protobuf name of a message type the space knows (e.g. URC.Pose2D)");

  auto* context = app.add_subcommand("context", "Read and write context entries");
  context->require_subcommand(1);
  std::string key;
  std::string value;
  int ttl_ms = 0;
  auto* cget = context->add_subcommand("get", "Print the entry KEY");
  cget->add_option("key", key)->required();
  auto* cset = context->add_subcommand("set", "Set KEY to a JSON value");
  cset->add_option("key", key)->required();
  cset->add_option("json", value, "JSON value: number, string, bool, object, list or null")->required();
  cset->add_option("--ttl-ms", ttl_ms, "Expire after this long (0 = never)");
  auto* cls = context->add_subcommand("ls", "List entries (glob PATTERN)");
  cls->add_option("pattern", pattern);
  auto* crm = context->add_subcommand("rm", "Delete KEY");
  crm->add_option("key", key)->required();

  auto* task = app.add_subcommand("task", "Define, run, inspect and cancel tasks");
  task->require_subcommand(1);
  std::string name;
  std::string file;
  bool wait = false;
  auto* tdefine = task->add_subcommand("define", "Define (or replace) a task from a YAML FILE");
  tdefine->add_option("file", file)->required()->check(CLI::ExistingFile);
  auto* trun = task->add_subcommand("run", "Run the task NAME, or the YAML FILE given with --file");
  trun->add_option("name", name);
  trun->add_option("--file", file, "Run this YAML definition inline")->check(CLI::ExistingFile);
  trun->add_flag("--wait", wait, "Wait until the run ends; exit 1 unless it succeeded");
  auto* tstatus = task->add_subcommand("status", "Status of run ID, or of the latest run of task NAME");
  tstatus->add_option("run", name)->required();
  auto* tcancel = task->add_subcommand("cancel", "Cancel run ID");
  tcancel->add_option("run", name)->required();
  auto* tls = task->add_subcommand("ls", "List task definitions and runs");

  urs::cli::RtcCommands rtc(app);

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kOk : kUsage;  // --help exits 0; anything else is bad usage
  }
  if (rtc.selected()) return rtc.run(log_level);
  if (*link_command) {  // no CAMUS server: the bridge's metrics endpoint
    if (timeout_ms <= 0) {
      std::cerr << "urs: --timeout-ms: " << timeout_ms << " must be positive\n";
      return kUsage;
    }
    return urs::cli::run_link_command(link_bridge, json_out, std::chrono::milliseconds(timeout_ms)) == 0 ? kOk
                                                                                                         : kFailed;
  }

  urs::planet::ClientOptions options;
  try {
    urs::util::init_logging({"urs", log_level, log_format, {}});
    auto endpoint = urs::util::parse_endpoint(server, "--server");
    options.host = endpoint.host;
    options.port = endpoint.port;
    if (token_file.empty()) token_file = env_or("URS_TOKEN_FILE", "");
    options.token = token_file.empty() ? env_or("URS_TOKEN", "") : urs::util::read_token_file(token_file);
    urs::util::check_tls_client(tls_config);
    options.tls = tls_config;
  } catch (const std::exception& e) {
    std::cerr << "urs: " << e.what() << "\n";
    return kUsage;
  }
  if (timeout_ms <= 0) {
    std::cerr << "urs: --timeout-ms: " << timeout_ms << " must be positive\n";
    return kUsage;
  }
  const auto timeout = std::chrono::milliseconds(timeout_ms);
  options.peer_name = "urs-cli";
  options.max_queued = 64;
  urs::planet::Client client(options);
  client.start();
  if (!client.wait_connected(timeout)) {
    auto why = client.last_error();
    std::cerr << "urs: cannot reach the CAMUS server at " << server << ": "
              << (why.empty() ? "no answer within " + std::to_string(timeout_ms) + " ms" : why) << "\n";
    return kUnreachable;
  }
  urs::cli::DynamicCaller caller(client, timeout);

  try {
    if (*whoami) {
      const auto welcome = client.welcome();
      std::printf("%s %s %s\n", welcome.identity().c_str(), urs::planet::role_word(welcome.role()),
                  welcome.space().c_str());
      return kOk;
    }
    if (*ls) {
      camus::ListRequest request;
      request.set_pattern(pattern);
      camus::ListReply reply;
      int rc = builtin(client, "camus.registry", "List", request, timeout, reply, json_out);
      if (rc != kOk || json_out) return rc;
      // ORIGIN: "native" for a service agent of this space; what a bridge offers names where the
      // service really is ("rtc:<naming path>:<port>"). OWNER is the providers' authenticated
      // identity; PEER the names they declared (display only), one per provider, comma-separated,
      // longest registered first. STATE: the registry's, unless the provider reports it cannot
      // serve (urslink.health of a bridged RT provider: slow, inactive, error; of another space's
      // service: "unreachable <how long>" while that space is lost).
      std::printf("%-32s %-28s %-20s %-20s %-10s %s\n", "SERVICE", "INTERFACE", "OWNER", "PEER", "STATE", "ORIGIN");
      for (const auto& s : reply.services()) {
        const auto origin = s.properties().find("urslink.origin");
        const auto health = s.properties().find("urslink.health");
        std::string state = health == s.properties().end() || health->second == "ok" ? s.state() : health->second;
        const auto since = s.properties().find("urslink.unreachable_since");
        if (health != s.properties().end() && health->second == "unreachable" && since != s.properties().end()) {
          state += " " + unreachable_for(since->second);
        }
        std::string peers;
        for (const auto& provider : s.providers()) {
          peers += (peers.empty() ? "" : ",") + (provider.peer_name().empty() ? "-" : provider.peer_name());
        }
        if (peers.empty()) peers = s.peer_name().empty() ? "-" : s.peer_name();
        std::printf("%-32s %-28s %-20s %-20s %-10s %s\n", s.name().c_str(), s.interface().c_str(), s.owner().c_str(),
                    peers.c_str(), state.c_str(), origin == s.properties().end() ? "native" : origin->second.c_str());
      }
      return kOk;
    }
    if (*spaces) {
      camus::ListRequest request;
      camus::ListReply reply;
      int rc = builtin(client, "camus.registry", "List", request, timeout, reply, json_out);
      if (rc != kOk || json_out) return rc;
      // Per other space, from its services a bridge registered here (urslink.space): UNREACHABLE
      // for how long while its bridges are all lost (urslink.health, urslink.unreachable_since),
      // how many of its services are here, and which bridges of this space brought them.
      struct Space {
        std::size_t services = 0;
        std::string unreachable;  // "" while reachable, else for how long
        std::set<std::string> bridges;
      };
      std::map<std::string, Space> seen;
      for (const auto& s : reply.services()) {
        const auto space = s.properties().find("urslink.space");
        if (space == s.properties().end()) continue;
        Space& entry = seen[space->second];
        ++entry.services;
        const auto bridge = s.properties().find("urslink.bridge");
        if (bridge != s.properties().end()) entry.bridges.insert(bridge->second);
        const auto health = s.properties().find("urslink.health");
        const auto since = s.properties().find("urslink.unreachable_since");
        if (health != s.properties().end() && health->second == "unreachable") {
          entry.unreachable = since == s.properties().end() ? "?" : unreachable_for(since->second);
        }
      }
      std::printf("%-16s %-20s %-9s %s\n", "SPACE", "STATE", "SERVICES", "BRIDGES");
      for (const auto& [name, space] : seen) {
        std::string bridges;
        for (const auto& bridge : space.bridges) bridges += (bridges.empty() ? "" : ",") + bridge;
        const std::string state = space.unreachable.empty() ? "reachable" : "unreachable " + space.unreachable;
        std::printf("%-16s %-20s %-9zu %s\n", name.c_str(), state.c_str(), space.services,
                    bridges.empty() ? "-" : bridges.c_str());
      }
      return kOk;
    }
    if (*describe) {
      std::string text;
      auto result = caller.describe(service, text);
      if (!result.ok()) return report("describe " + service, result);
      std::cout << text;
      return kOk;
    }
    if (*call) {
      auto deadline = std::chrono::milliseconds(deadline_ms);
      // The call's trace, which every hop logs (docs/operations.md, "Following one call"): the
      // caller's, or a new one; its id on stderr (util::show_trace_id), so that stdout stays the reply alone.
      auto trace = urs::util::TraceContext::start();
      if (!traceparent.empty()) {
        auto given = urs::util::TraceContext::parse(traceparent);
        if (!given) {
          std::cerr << "urs: --traceparent: '" << traceparent.substr(0, 64)
                    << "' is not a W3C traceparent (00-<32 hex>-<16 hex>-<2 hex>, lower case, ids not all zero)\n";
          return kUsage;
        }
        trace = *given;
      }
      urs::util::TraceScope scope(trace);
      auto out = caller.call(service, operation, args, deadline);
      urs::util::show_trace_id(trace, show_trace || !out.result.ok());
      if (!out.result.ok()) {
        int rc = report(service + "." + operation, out.result, out.json);
        return out.result.status == urs::planet::BAD_ARGUMENTS && out.result.payload.empty() ? kUsage : rc;
      }
      std::cout << (out.json.empty() ? "{}" : out.json) << "\n";
      return kOk;
    }
    if (*watch) {
      // Events arrive on the client's I/O thread, which must not block; decoding may need to
      // ask the registry for an interface, so events are handed to this thread first. The inbox
      // is shared with the handler (which may still be running when this block ends) and the
      // subscription ends before the block does.
      struct Inbox {
        std::mutex mutex;
        std::condition_variable arrived;
        std::deque<urs::planet::Event> events;
      };
      auto inbox = std::make_shared<Inbox>();
      const uint64_t subscription = client.subscribe(
          pattern,
          [inbox](const urs::planet::Event& event) {
            std::lock_guard<std::mutex> lock(inbox->mutex);
            inbox->events.push_back(event);
            inbox->arrived.notify_all();
          },
          resume_after);
      const auto until = for_ms > 0 ? std::chrono::steady_clock::now() + std::chrono::milliseconds(for_ms)
                                    : std::chrono::steady_clock::time_point::max();
      int seen = 0;
      while (count == 0 || seen < count) {
        std::unique_lock<std::mutex> lock(inbox->mutex);
        if (!inbox->arrived.wait_until(lock, until, [&] { return !inbox->events.empty(); })) break;
        urs::planet::Event event = std::move(inbox->events.front());
        inbox->events.pop_front();
        lock.unlock();
        std::cout << caller.event_json(event) << std::endl;
        ++seen;
      }
      client.unsubscribe(subscription);
      return count > 0 && seen < count ? kFailed : kOk;
    }
    if (*pub) {
      // A typed event is encoded with the type's description (compiled in, or asked from the
      // registry); without a type the JSON text itself is the payload.
      std::string payload;
      std::string content_type = "application/json";
      if (type.empty()) {
        google::protobuf::Value parsed;
        auto error = urs::schema::json_to_message(args, parsed);
        if (!error.empty()) {
          std::cerr << "urs: pub " << topic << ": '" << args << "' is not JSON: " << error << "\n";
          return kUsage;
        }
        payload = args;
      } else {
        const auto* descriptor = caller.find_type(type);
        if (descriptor == nullptr) {
          std::cerr << "urs: pub " << topic << ": the space knows no message type " << type
                    << " (no registered interface describes it)\n";
          return kFailed;
        }
        auto message = caller.new_message(*descriptor);
        auto error = urs::schema::json_to_message(args, *message);
        if (!error.empty()) {
          std::cerr << "urs: pub " << topic << ": " << error << "\n";
          return kUsage;
        }
        payload = message->SerializeAsString();
        content_type = type;
      }
      auto result = client.publish_and_wait(topic, std::move(payload), content_type, timeout);
      if (!result.ok()) return report("pub " + topic, result);
      return kOk;
    }
    if (*context) {
      if (*cget) {
        camus::ContextGetRequest request;
        request.set_key(key);
        camus::ContextEntry reply;
        return builtin(client, "camus.context", "Get", request, timeout, reply);
      }
      if (*cset) {
        camus::ContextSetRequest request;
        request.set_key(key);
        request.set_ttl_ms(static_cast<uint32_t>(ttl_ms));
        auto error = urs::schema::json_to_message(value, *request.mutable_value());
        if (!error.empty()) {
          std::cerr << "urs: context set " << key << ": value '" << value << "' is not JSON: " << error << "\n";
          return kUsage;
        }
        camus::ContextEntry reply;
        return builtin(client, "camus.context", "Set", request, timeout, reply);
      }
      if (*cls) {
        camus::ContextListRequest request;
        request.set_pattern(pattern);
        camus::ContextListReply reply;
        return builtin(client, "camus.context", "List", request, timeout, reply);
      }
      camus::ContextDeleteRequest request;
      request.set_key(key);
      camus::ContextDeleteReply reply;
      return builtin(client, "camus.context", "Delete", request, timeout, reply, false);
    }
    if (*task) {
      if (*tdefine) {
        camus::TaskDefinition request;
        request.set_yaml(read_file(file));
        camus::TaskDefineReply reply;
        return builtin(client, "camus.tasks", "Define", request, timeout, reply);
      }
      if (*trun) {
        if (name.empty() == file.empty()) {
          std::cerr << "urs: task run: give a task NAME or --file FILE (exactly one)\n";
          return kUsage;
        }
        camus::TaskRunRequest request;
        if (!file.empty()) request.set_yaml(read_file(file));
        request.set_name(name);
        camus::TaskRun run;
        if (!wait) return builtin(client, "camus.tasks", "Run", request, timeout, run);
        // Subscribe before starting so that no state change can be missed.
        std::mutex mutex;
        std::condition_variable changed;
        std::map<std::string, camus::TaskRun> latest;  // by run id
        client.subscribe("task/#", [&](const urs::planet::Event& event) {
          camus::TaskRun update;
          if (!update.ParseFromString(event.payload())) return;
          std::lock_guard<std::mutex> lock(mutex);
          latest[update.run_id()] = update;
          changed.notify_all();
        });
        int rc = builtin(client, "camus.tasks", "Run", request, timeout, run, false);
        if (rc != kOk) return rc;
        std::unique_lock<std::mutex> lock(mutex);
        latest.emplace(run.run_id(), run);  // keeps a newer update if one arrived first
        changed.wait(lock, [&] { return latest[run.run_id()].state() != "running"; });
        const camus::TaskRun& last = latest[run.run_id()];
        std::cout << to_json(last) << "\n";
        return last.state() == "succeeded" ? kOk : kFailed;
      }
      if (*tstatus || *tcancel) {
        camus::TaskRun reply;
        if (*tcancel) {
          camus::TaskCancelRequest request;
          request.set_run_id(name);
          return builtin(client, "camus.tasks", "Cancel", request, timeout, reply);
        }
        camus::TaskStatusRequest request;
        // A run id or a task name: the server answers for whichever matches.
        request.set_run_id(name);
        request.set_name(name);
        return builtin(client, "camus.tasks", "Status", request, timeout, reply);
      }
      if (*tls) {
        camus::TaskListReply reply;
        return builtin(client, "camus.tasks", "List", camus::TaskListRequest(), timeout, reply);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "urs: " << e.what() << "\n";
    return kUsage;
  }
  return kUsage;
}
