#include "urs/corba_agent/agent_servant.hpp"

#include <omniORB4/anyStream.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>

#include "idl_type.hpp"
#include "urs/corba_agent/type_codes.hpp"
#include "urs/rtc/trace_context.hpp"
#include "urs/util/trace.hpp"

namespace urs::corba_agent {

using google::protobuf::Descriptor;
using google::protobuf::FieldDescriptor;
using google::protobuf::Message;
using google::protobuf::MethodDescriptor;

struct AgentServant::Operation {
  struct Argument {
    std::string name;
    CORBA::Flags mode = CORBA::ARG_IN;
    CORBA::TypeCode_var type;
    const FieldDescriptor* in = nullptr;   // its Request field (in, inout)
    const FieldDescriptor* out = nullptr;  // its Reply field (out, inout)
  };
  struct Raised {
    const Descriptor* type = nullptr;
    CORBA::TypeCode_var type_code;
  };

  const MethodDescriptor* method = nullptr;
  bool oneway = false;
  std::vector<Argument> arguments;  // in IDL signature order
  const FieldDescriptor* result = nullptr;
  CORBA::TypeCode_var result_type;
  std::map<std::string, Raised> raises;  // by the exception message's full name
};

namespace {

// What an Any's marshal function writes: one field of a message, or the whole message.
struct Marshal {
  const CdrCodec& codec;
  const Message& message;
  const FieldDescriptor* field;  // nullptr: the whole message
};

void marshal(cdrStream& stream, void* data) {
  const auto& what = *static_cast<const Marshal*>(data);
  if (what.field != nullptr) {
    what.codec.write_field(stream, what.message, *what.field);
  } else {
    what.codec.write(stream, what.message);
  }
}

void marshal_nothing(cdrStream&, void*) {}

// An Any holding a value of `type` marshalled by the codec from `what`. Throws ConversionError.
void insert(CORBA::Any& any, CORBA::TypeCode_ptr type, const Marshal& what) {
  any.PR_insert(type, marshal, const_cast<Marshal*>(&what));
}

// The system exception an agent's error status becomes (docs/devices.md).
[[noreturn]] void throw_system_exception(call::Status status) {
  switch (status) {
    case call::Status::BAD_ARGUMENTS:
      throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
    case call::Status::DEADLINE_EXCEEDED:
      throw CORBA::TIMEOUT(0, CORBA::COMPLETED_MAYBE);
    case call::Status::UNKNOWN_OPERATION:
      throw CORBA::BAD_OPERATION(0, CORBA::COMPLETED_NO);
    case call::Status::UNAVAILABLE:
      throw CORBA::TRANSIENT(0, CORBA::COMPLETED_NO);
    // A service reached through a bridge (urs::bridge) that is not there, or went away mid-call:
    // the caller may retry later, as for UNAVAILABLE.
    case call::Status::UNKNOWN_SERVICE:
      throw CORBA::TRANSIENT(0, CORBA::COMPLETED_NO);
    case call::Status::PROVIDER_GONE:
      throw CORBA::TRANSIENT(0, CORBA::COMPLETED_MAYBE);
    default:
      throw CORBA::INTERNAL(0, CORBA::COMPLETED_MAYBE);
  }
}

}  // namespace

AgentServant::AgentServant(CORBA::ORB_ptr orb, std::shared_ptr<agent::ServiceAgent> agent, agent::EventSink& events,
                           AgentServantOptions options)
    : agent_(std::move(agent)), events_(events), options_(std::move(options)), orb_(CORBA::ORB::_duplicate(orb)) {
  const auto& service = agent_->interface();
  const auto& service_options = service.options();
  repository_id_ = service_options.GetExtension(urs::options::service_repository_id);
  if (repository_id_.empty()) {
    throw std::invalid_argument(service.full_name() + " has no service_repository_id: not generated from IDL");
  }
  for (int i = 0; i < service_options.ExtensionSize(urs::options::service_bases); ++i) {
    base_ids_.push_back(service_options.GetExtension(urs::options::service_bases, i));
  }
  // Requests and replies are made by the generated factory when the agent's types are compiled
  // in (a TypedAgent casts to them), by dynamic messages otherwise.
  factory_.SetDelegateToGeneratedFactory(true);

  std::vector<const Descriptor*> roots;
  TypeCodes type_codes(orb);
  for (int m = 0; m < service.method_count(); ++m) {
    const MethodDescriptor* method = service.method(m);
    auto op = std::make_unique<Operation>();
    op->method = method;
    op->oneway = method->options().GetExtension(urs::options::oneway);
    roots.push_back(method->input_type());
    roots.push_back(method->output_type());
    std::map<std::uint32_t, Operation::Argument> by_position;
    const auto add_fields = [&](const Descriptor& message) {
      for (int f = 0; f < message.field_count(); ++f) {
        const FieldDescriptor* field = message.field(f);
        const auto mode = field->options().GetExtension(urs::options::param_mode);
        if (mode == urs::options::PARAM_MODE_RETURN) {
          op->result = field;
          op->result_type = type_codes.field(*field);
          continue;
        }
        auto& argument = by_position[field->options().GetExtension(urs::options::param_position)];
        argument.name = field->name();
        if (CORBA::is_nil(argument.type)) argument.type = type_codes.field(*field);
        switch (mode) {
          case urs::options::PARAM_MODE_IN:
            argument.mode = CORBA::ARG_IN, argument.in = field;
            break;
          case urs::options::PARAM_MODE_OUT:
            argument.mode = CORBA::ARG_OUT, argument.out = field;
            break;
          case urs::options::PARAM_MODE_INOUT:
            argument.mode = CORBA::ARG_INOUT;
            (message.options().GetExtension(urs::options::message_kind) == urs::options::MESSAGE_KIND_REQUEST
                 ? argument.in
                 : argument.out) = field;
            break;
          default:
            throw std::invalid_argument(field->full_name() + " has no param_mode: not generated from IDL");
        }
      }
    };
    add_fields(*method->input_type());
    add_fields(*method->output_type());
    for (auto& [position, argument] : by_position) op->arguments.push_back(std::move(argument));
    const auto& method_options = method->options();
    for (int r = 0; r < method_options.ExtensionSize(urs::options::raises); ++r) {
      const std::string name = method_options.GetExtension(urs::options::raises, r);
      const Descriptor* type = service.file()->pool()->FindMessageTypeByName(name);
      if (type == nullptr)
        throw std::invalid_argument(method->full_name() + " raises " + name + ", which is not in its pool");
      roots.push_back(type);
      op->raises[name] = Operation::Raised{type, type_codes.message(*type)};
    }
    operations_[method->name()] = std::move(op);
  }
  codec_ = std::make_unique<CdrCodec>(roots);
}

AgentServant::~AgentServant() = default;

std::string AgentServant::interface_name() const { return detail::scoped_name(repository_id_); }

char* AgentServant::_primary_interface(const PortableServer::ObjectId&, PortableServer::POA_ptr) {
  return CORBA::string_dup(repository_id_.c_str());
}

CORBA::Boolean AgentServant::_is_a(const char* repository_id) {
  const std::string id(repository_id);
  return id == repository_id_ || id == "IDL:omg.org/CORBA/Object:1.0" ||
         std::find(base_ids_.begin(), base_ids_.end(), id) != base_ids_.end();
}

const AgentServant::Operation& AgentServant::operation(const char* name) const {
  const auto it = operations_.find(name);
  if (it == operations_.end()) throw CORBA::BAD_OPERATION(0, CORBA::COMPLETED_NO);
  return *it->second;
}

namespace {

// Counts one call in `calls` when it goes out of scope, with the status set last (INTERNAL if an
// exception left before any was set), and logs its end at debug level (under the call's trace).
class Recorded {
 public:
  Recorded(call::CallRecorder* calls, const std::string& service)
      : calls_(calls), service_(service), start_(std::chrono::steady_clock::now()) {}
  ~Recorded() {
    const auto elapsed = std::chrono::steady_clock::now() - start_;
    if (calls_ != nullptr) calls_->record(service_, operation_, status_, elapsed);
    if (spdlog::should_log(spdlog::level::debug)) {
      spdlog::debug("served {}.{}: {} in {} us", service_, operation_.empty() ? "other" : operation_,
                    call::status_name(status_), std::chrono::duration_cast<std::chrono::microseconds>(elapsed).count());
    }
  }
  Recorded(const Recorded&) = delete;
  Recorded& operator=(const Recorded&) = delete;
  void operation(const std::string& name) { operation_ = name; }
  void status(call::Status status) { status_ = status; }

 private:
  call::CallRecorder* const calls_;
  const std::string& service_;
  const std::chrono::steady_clock::time_point start_;
  std::string operation_;
  call::Status status_ = call::Status::INTERNAL;
};

}  // namespace

void AgentServant::invoke(CORBA::ServerRequest_ptr request) {
  // The call's trace (from its service context): this servant's log lines and the calls and events
  // its agent makes meanwhile carry it.
  util::TraceScope trace(rtc::incoming_trace());
  Recorded recorded(options_.calls, options_.service_name);
  recorded.status(call::Status::UNKNOWN_OPERATION);
  const Operation& op = operation(request->operation());
  recorded.operation(op.method->name());
  recorded.status(call::Status::BAD_ARGUMENTS);
  CORBA::NVList_var arguments;
  orb_->create_list(static_cast<CORBA::Long>(op.arguments.size()), arguments.out());
  for (const auto& argument : op.arguments) {
    CORBA::Any slot;  // typed and empty: arguments() fills the in and inout ones
    slot.PR_insert(argument.type, marshal_nothing, nullptr);
    arguments->add_value(argument.name.c_str(), slot, argument.mode);
  }
  // The request owns the list from here on and releases it after the reply.
  CORBA::NVList_ptr received = arguments._retn();
  request->arguments(received);

  std::unique_ptr<Message> in(factory_.GetPrototype(op.method->input_type())->New());
  try {
    for (CORBA::ULong i = 0; i < op.arguments.size(); ++i) {
      if (op.arguments[i].in == nullptr) continue;
      cdrAnyMemoryStream value(received->item(i)->value()->PR_streamToRead(), true);
      codec_->read_field(value, *in, *op.arguments[i].in);
    }
  } catch (const ConversionError& e) {
    spdlog::warn("{}: {}: refused: {}", options_.service_name, op.method->name(), e.what());
    throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_NO);
  }

  std::unique_ptr<Message> out(factory_.GetPrototype(op.method->output_type())->New());
  agent::CallContext context{options_.service_name, {}, std::chrono::steady_clock::now() + options_.deadline, &events_};
  agent::Outcome outcome;
  try {
    outcome = agent_->invoke(*op.method, *in, *out, context);
  } catch (const std::exception& e) {
    outcome = agent::Outcome::error(call::Status::INTERNAL, e.what());
  }
  recorded.status(outcome.status);
  if (op.oneway) {
    if (outcome.status != call::Status::OK) {
      spdlog::warn("{}: oneway {} failed: {} {}", options_.service_name, op.method->name(),
                   call::status_name(outcome.status), outcome.message);
    }
    return;
  }
  answer(request, op, received, outcome, *out);
}

void AgentServant::answer(CORBA::ServerRequest_ptr request, const Operation& op, CORBA::NVList_ptr arguments,
                          const agent::Outcome& outcome, const Message& reply) {
  if (outcome.status == call::Status::USER_EXCEPTION && outcome.exception) {
    const auto raised = op.raises.find(outcome.exception->GetDescriptor()->full_name());
    if (raised == op.raises.end()) {
      spdlog::warn("{}: {} raised {}, which the operation does not declare", options_.service_name, op.method->name(),
                   outcome.exception->GetDescriptor()->full_name());
      throw CORBA::UNKNOWN(0, CORBA::COMPLETED_YES);
    }
    CORBA::Any exception;
    try {
      insert(exception, raised->second.type_code, Marshal{*codec_, *outcome.exception, nullptr});
    } catch (const ConversionError& e) {
      spdlog::warn("{}: {}: the exception cannot be sent: {}", options_.service_name, op.method->name(), e.what());
      throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_YES);
    }
    request->set_exception(exception);
    return;
  }
  if (outcome.status != call::Status::OK) {
    spdlog::debug("{}: {}: {} {}", options_.service_name, op.method->name(), call::status_name(outcome.status),
                  outcome.message);
    throw_system_exception(outcome.status);
  }
  try {
    for (CORBA::ULong i = 0; i < op.arguments.size(); ++i) {
      const auto& argument = op.arguments[i];
      if (argument.out != nullptr)
        insert(*arguments->item(i)->value(), argument.type, Marshal{*codec_, reply, argument.out});
    }
    if (op.result != nullptr) {
      CORBA::Any result;
      insert(result, op.result_type, Marshal{*codec_, reply, op.result});
      request->set_result(result);
    }
  } catch (const ConversionError& e) {
    spdlog::warn("{}: {}: the reply cannot be sent: {}", options_.service_name, op.method->name(), e.what());
    throw CORBA::BAD_PARAM(0, CORBA::COMPLETED_YES);
  }
}

}  // namespace urs::corba_agent
