#include "urs/corba_agent/corba_proxy.hpp"

#include <omniORB4/anyStream.h>
#include <omniORB4/minorCode.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "idl_type.hpp"
#include "urs/corba_agent/type_codes.hpp"
#include "urs/rtc/orb.hpp"

namespace urs::corba_agent {

namespace gp = google::protobuf;

struct CorbaProxyAgent::Call {
  // One parameter in IDL signature order; `sent` is its Request field (in, inout), `received`
  // its Reply field (out, inout).
  struct Parameter {
    std::string name;
    CORBA::Flags mode = CORBA::ARG_IN;
    CORBA::TypeCode_var type;
    const gp::FieldDescriptor* sent = nullptr;
    const gp::FieldDescriptor* received = nullptr;
  };
  struct Declared {
    const gp::Message* prototype = nullptr;
    CORBA::TypeCode_var type;
  };

  std::string operation;  // the GIOP operation name ("_get_speed" for an attribute)
  bool oneway = false;
  std::vector<Parameter> parameters;
  const gp::FieldDescriptor* result = nullptr;
  CORBA::TypeCode_var result_type;
  std::map<std::string, Declared> declared;  // user exceptions by repository ID
};

namespace {

// The codec writing one Request field into an Any's stream, as its marshal function.
struct FieldSource {
  const CdrCodec& codec;
  const gp::Message& message;
  const gp::FieldDescriptor& field;
};

void write_field(cdrStream& stream, void* data) {
  const auto& source = *static_cast<const FieldSource*>(data);
  source.codec.write_field(stream, source.message, source.field);
}

void write_nothing(cdrStream&, void*) {}

// The value a reply or exception Any holds, decoded into `message` (one field, or all of it).
void read_any(const CdrCodec& codec, CORBA::Any& any, gp::Message& message, const gp::FieldDescriptor* field) {
  cdrAnyMemoryStream stream(any.PR_streamToRead(), true);
  if (field != nullptr) {
    codec.read_field(stream, message, *field);
  } else {
    codec.read(stream, message);
  }
}

// True for the exceptions of a call whose timeout passed (omniORB raises either).
bool timed_out(const CORBA::SystemException& e) {
  return dynamic_cast<const CORBA::TIMEOUT*>(&e) != nullptr ||
         (dynamic_cast<const CORBA::TRANSIENT*>(&e) != nullptr && e.minor() == omni::TRANSIENT_CallTimedout);
}

// The status a CORBA system exception becomes for the agent's caller (docs/bridge.md).
agent::Outcome from_system_exception(const CORBA::SystemException& e, const std::string& operation) {
  const std::string what = operation + ": " + rtc::describe(e);
  if (timed_out(e)) return agent::Outcome::error(call::Status::DEADLINE_EXCEEDED, "deadline passed: " + what);
  if (dynamic_cast<const CORBA::TRANSIENT*>(&e) != nullptr || dynamic_cast<const CORBA::COMM_FAILURE*>(&e) != nullptr ||
      dynamic_cast<const CORBA::OBJECT_NOT_EXIST*>(&e) != nullptr) {
    return agent::Outcome::error(call::Status::UNAVAILABLE, "provider gone: " + what);
  }
  if (dynamic_cast<const CORBA::BAD_PARAM*>(&e) != nullptr || dynamic_cast<const CORBA::MARSHAL*>(&e) != nullptr) {
    return agent::Outcome::error(call::Status::BAD_ARGUMENTS, "refused by the provider: " + what);
  }
  if (dynamic_cast<const CORBA::BAD_OPERATION*>(&e) != nullptr ||
      dynamic_cast<const CORBA::NO_IMPLEMENT*>(&e) != nullptr) {
    return agent::Outcome::error(call::Status::UNKNOWN_OPERATION, "not served by the provider: " + what);
  }
  return agent::Outcome::error(call::Status::INTERNAL, "provider failed: " + what);
}

std::string repository_id_of(const gp::Descriptor& message) {
  return message.options().GetExtension(urs::options::message_repository_id);
}

}  // namespace

CorbaProxyAgent::CorbaProxyAgent(CORBA::ORB_ptr orb, CORBA::Object_ptr target, const gp::ServiceDescriptor& interface,
                                 CorbaProxyOptions options)
    : interface_(interface), options_(options), orb_(CORBA::ORB::_duplicate(orb)) {
  if (CORBA::is_nil(target)) throw std::invalid_argument("no CORBA object to proxy " + interface.full_name() + " to");
  if (interface.options().GetExtension(urs::options::service_repository_id).empty()) {
    throw std::invalid_argument(interface.full_name() + " has no service_repository_id: not generated from IDL");
  }
  CORBA::String_var ior = orb_->object_to_string(target);
  target_ior_ = ior.in();
  // Exceptions are made as the generated classes when those are compiled in, so a caller that
  // casts them (as TypedAgent callers do) sees the type it expects.
  factory_.SetDelegateToGeneratedFactory(true);

  TypeCodes type_codes(orb);
  std::vector<const gp::Descriptor*> roots;
  for (int m = 0; m < interface.method_count(); ++m) {
    const gp::MethodDescriptor* method = interface.method(m);
    const auto& method_options = method->options();
    auto call = std::make_unique<Call>();
    // Attribute accessors are already named as on the wire ("_get_speed").
    call->operation = method->name();
    call->oneway = method_options.GetExtension(urs::options::oneway);
    roots.push_back(method->input_type());
    roots.push_back(method->output_type());

    std::map<std::uint32_t, Call::Parameter> by_position;
    const auto parameter_of = [&](const gp::FieldDescriptor& field) -> Call::Parameter& {
      auto& parameter = by_position[field.options().GetExtension(urs::options::param_position)];
      parameter.name = field.name();
      if (CORBA::is_nil(parameter.type)) parameter.type = type_codes.field(field);
      return parameter;
    };
    const gp::Descriptor& request = *method->input_type();
    for (int f = 0; f < request.field_count(); ++f) {
      const gp::FieldDescriptor& field = *request.field(f);
      Call::Parameter& parameter = parameter_of(field);
      parameter.sent = &field;
      parameter.mode = field.options().GetExtension(urs::options::param_mode) == urs::options::PARAM_MODE_INOUT
                           ? CORBA::ARG_INOUT
                           : CORBA::ARG_IN;
    }
    const gp::Descriptor& reply = *method->output_type();
    for (int f = 0; f < reply.field_count(); ++f) {
      const gp::FieldDescriptor& field = *reply.field(f);
      const auto mode = field.options().GetExtension(urs::options::param_mode);
      if (mode == urs::options::PARAM_MODE_RETURN) {
        call->result = &field;
        call->result_type = type_codes.field(field);
        continue;
      }
      if (mode != urs::options::PARAM_MODE_OUT && mode != urs::options::PARAM_MODE_INOUT) {
        throw std::invalid_argument(field.full_name() + " has no out param_mode: not generated from IDL");
      }
      Call::Parameter& parameter = parameter_of(field);
      parameter.received = &field;
      parameter.mode = mode == urs::options::PARAM_MODE_INOUT ? CORBA::ARG_INOUT : CORBA::ARG_OUT;
    }
    for (auto& [position, parameter] : by_position) call->parameters.push_back(std::move(parameter));

    for (int r = 0; r < method_options.ExtensionSize(urs::options::raises); ++r) {
      const std::string name = method_options.GetExtension(urs::options::raises, r);
      const gp::Descriptor* type = interface.file()->pool()->FindMessageTypeByName(name);
      if (type == nullptr)
        throw std::invalid_argument(method->full_name() + " raises " + name + ", which is not in its pool");
      roots.push_back(type);
      call->declared[repository_id_of(*type)] = Call::Declared{factory_.GetPrototype(type), type_codes.message(*type)};
    }
    calls_[method] = std::move(call);
  }
  codec_ = std::make_unique<CdrCodec>(roots);
}

CorbaProxyAgent::~CorbaProxyAgent() = default;

CORBA::Object_ptr CorbaProxyAgent::reference_for(std::chrono::milliseconds timeout) const {
  // omniORB keeps a call timeout per object reference: each thread calling through this proxy has
  // a reference of its own (made once), so calls with different deadlines never share a setting.
  CORBA::Object_var reference;
  {
    std::lock_guard lock(references_mutex_);
    CORBA::Object_var& mine = references_[std::this_thread::get_id()];
    if (CORBA::is_nil(mine)) mine = orb_->string_to_object(target_ior_.c_str());
    reference = CORBA::Object::_duplicate(mine);
  }
  omniORB::setClientCallTimeout(reference, static_cast<CORBA::ULong>(std::max<std::int64_t>(1, timeout.count())));
  return reference._retn();
}

agent::Outcome CorbaProxyAgent::invoke(const gp::MethodDescriptor& method, const gp::Message& request,
                                       gp::Message& reply, const agent::CallContext& ctx) {
  const auto found = calls_.find(&method);
  if (found == calls_.end()) {
    return agent::Outcome::error(call::Status::UNKNOWN_OPERATION,
                                 interface_.full_name() + " has no operation " + method.full_name());
  }
  const Call& call = *found->second;

  const auto now = std::chrono::steady_clock::now();
  auto timeout = ctx.deadline == std::chrono::steady_clock::time_point::max()
                     ? options_.default_deadline
                     : std::chrono::ceil<std::chrono::milliseconds>(ctx.deadline - now);
  if (options_.max_deadline.count() > 0) timeout = std::min(timeout, options_.max_deadline);
  if (timeout.count() <= 0) {
    return agent::Outcome::error(call::Status::DEADLINE_EXCEEDED,
                                 "deadline passed before " + call.operation + " was sent");
  }

  try {
    CORBA::Object_var target = reference_for(timeout);
    CORBA::Request_var dii = target->_request(call.operation.c_str());
    for (const auto& parameter : call.parameters) {
      CORBA::Any& slot = parameter.mode == CORBA::ARG_IN    ? dii->add_in_arg(parameter.name.c_str())
                         : parameter.mode == CORBA::ARG_OUT ? dii->add_out_arg(parameter.name.c_str())
                                                            : dii->add_inout_arg(parameter.name.c_str());
      if (parameter.sent != nullptr) {
        FieldSource source{*codec_, request, *parameter.sent};
        slot.PR_insert(parameter.type, write_field, &source);
      } else {
        // Typed and empty: the reply is read into it with this TypeCode.
        slot.PR_insert(parameter.type, write_nothing, nullptr);
      }
    }
    dii->set_return_type(call.result != nullptr ? call.result_type.in() : CORBA::_tc_void);
    for (const auto& [id, declared] : call.declared) dii->exceptions()->add(declared.type);

    if (call.oneway) {
      dii->send_oneway();
      return agent::Outcome::ok();
    }
    dii->invoke();
    // omniORB's call timeout can let a reply through past it under load (a 200 ms call with a 50 ms
    // timeout, seen in CI): a reply that comes after the caller's deadline is not an answer in time.
    if (ctx.deadline != std::chrono::steady_clock::time_point::max()) {
      const auto late = std::chrono::steady_clock::now() - ctx.deadline;
      if (late > std::chrono::steady_clock::duration::zero()) {
        return agent::Outcome::error(
            call::Status::DEADLINE_EXCEEDED,
            "deadline passed: " + call.operation + "'s reply came " +
                std::to_string(std::chrono::duration_cast<std::chrono::milliseconds>(late).count()) + " ms after it");
      }
    }
    if (CORBA::Exception* raised = dii->env()->exception()) {
      if (auto* user = CORBA::UnknownUserException::_downcast(raised)) return answer_user_exception(call, *user);
      if (auto* system = CORBA::SystemException::_downcast(raised)) return answer_system_exception(call, *system);
      return agent::Outcome::error(call::Status::INTERNAL, call.operation + ": " + rtc::describe(*raised));
    }
    try {
      for (CORBA::ULong i = 0; i < call.parameters.size(); ++i) {
        const auto& parameter = call.parameters[i];
        if (parameter.received != nullptr)
          read_any(*codec_, *dii->arguments()->item(i)->value(), reply, parameter.received);
      }
      if (call.result != nullptr) read_any(*codec_, dii->return_value(), reply, call.result);
    } catch (const ConversionError& e) {
      return agent::Outcome::error(call::Status::INTERNAL,
                                   call.operation + ": the provider's reply cannot be read: " + e.what());
    }
    return agent::Outcome::ok();
  } catch (const ConversionError& e) {
    return agent::Outcome::error(call::Status::BAD_ARGUMENTS, call.operation + ": " + e.what());
  } catch (const CORBA::SystemException& e) {
    return answer_system_exception(call, e);
  }
}

agent::Outcome CorbaProxyAgent::answer_system_exception(const Call& call, const CORBA::SystemException& raised) const {
  if (options_.explain_missing_target && dynamic_cast<const CORBA::OBJECT_NOT_EXIST*>(&raised) != nullptr) {
    const std::string why = options_.explain_missing_target();
    if (!why.empty()) return agent::Outcome::error(call::Status::UNAVAILABLE, call.operation + ": " + why);
  }
  if (options_.max_calls_per_peer > 0 && raised.completed() == CORBA::COMPLETED_NO && timed_out(raised)) {
    // Never sent: the ORB waited for a connection to the provider's process that did not come.
    return agent::Outcome::error(
        call::Status::DEADLINE_EXCEEDED,
        "deadline passed before " + call.operation + " was sent (" + rtc::describe(raised) +
            "): the provider's process did not accept a connection in time, or this process's " +
            std::to_string(options_.max_calls_per_peer) +
            " calls to it at most (max_calls_per_peer) were all in flight");
  }
  return from_system_exception(raised, call.operation);
}

agent::Outcome CorbaProxyAgent::answer_user_exception(const Call& call, CORBA::UnknownUserException& raised) const {
  CORBA::Any& value = raised.exception();
  CORBA::TypeCode_var type = value.type();
  const std::string id = type->id();
  const auto declared = call.declared.find(id);
  if (declared == call.declared.end()) {
    return agent::Outcome::error(call::Status::INTERNAL,
                                 call.operation + " raised " + id + ", which it does not declare");
  }
  std::shared_ptr<gp::Message> exception(declared->second.prototype->New());
  try {
    read_any(*codec_, value, *exception, nullptr);
  } catch (const ConversionError& e) {
    return agent::Outcome::error(call::Status::INTERNAL,
                                 call.operation + " raised an exception that cannot be read: " + e.what());
  }
  const std::string text = call.operation + " raised " + exception->GetTypeName();
  return agent::Outcome::raise(std::move(exception), text);
}

}  // namespace urs::corba_agent
