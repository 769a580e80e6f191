#pragma once
// TypedAgent: write a ServiceAgent against the C++ classes generated from an IDL interface.
//
//   class Echo : public TypedAgent {
//    public:
//     Echo() : TypedAgent(*URS::Diagnostic_echo_Request::descriptor()->file(), "Diagnostic") {
//       on<URS::Diagnostic_echo_Request, URS::Diagnostic_echo_Reply>("echo",
//           [](const auto& req, auto& rep, const CallContext&) { rep.set_result(req.text()); return Outcome::ok(); });
//     }
//   };
//
// Every operation of the interface must get a handler (checked by the constructor's caller with
// check_complete()); a missing one answers UNKNOWN_OPERATION naming it as not implemented. A
// handler that never blocks and does bounded work may be registered with Run::on_receiving_thread
// (ServiceAgent::runs_inline): its calls then cost no thread hand-off.

#include <functional>
#include <stdexcept>
#include <string>
#include <unordered_map>

#include "urs/agent/agent.hpp"

namespace urs::agent {

class TypedAgent : public ServiceAgent {
 public:
  const google::protobuf::ServiceDescriptor& interface() const override { return *interface_; }

  Outcome invoke(const google::protobuf::MethodDescriptor& method, const google::protobuf::Message& request,
                 google::protobuf::Message& reply, const CallContext& ctx) override {
    auto it = handlers_.find(method.name());
    if (it == handlers_.end()) {
      return Outcome::error(call::Status::UNKNOWN_OPERATION,
                            interface_->full_name() + "." + method.name() + " is not implemented by this agent");
    }
    return it->second.fn(request, reply, ctx);
  }

  bool runs_inline(const google::protobuf::MethodDescriptor& method) const override {
    auto it = handlers_.find(method.name());
    return it != handlers_.end() && it->second.run == Run::on_receiving_thread;
  }

  // Throws std::logic_error naming the first operation without a handler.
  void check_complete() const {
    for (int i = 0; i < interface_->method_count(); ++i) {
      if (handlers_.count(interface_->method(i)->name()) == 0) {
        throw std::logic_error(interface_->full_name() + "." + interface_->method(i)->name() + " has no handler");
      }
    }
  }

 protected:
  // Where a handler runs: on one of the host's workers (it may block), or on the thread that
  // received the call (it never blocks and its work is bounded).
  enum class Run { on_worker, on_receiving_thread };

  // Throws std::logic_error if the file declares no such service.
  TypedAgent(const google::protobuf::FileDescriptor& file, const std::string& service_name)
      : interface_(file.FindServiceByName(service_name)) {
    if (interface_ == nullptr) {
      throw std::logic_error(file.name() + " declares no service '" + service_name + "'");
    }
  }

  template <class Req, class Rep>
  void on(const std::string& operation, std::function<Outcome(const Req&, Rep&, const CallContext&)> fn,
          Run run = Run::on_worker) {
    const auto* method = interface_->FindMethodByName(operation);
    if (method == nullptr || method->input_type() != Req::descriptor() || method->output_type() != Rep::descriptor()) {
      throw std::logic_error("handler for " + interface_->full_name() + "." + operation +
                             " does not match the interface");
    }
    handlers_[operation] = {[fn = std::move(fn)](const google::protobuf::Message& request,
                                                 google::protobuf::Message& reply, const CallContext& ctx) {
                              return fn(static_cast<const Req&>(request), static_cast<Rep&>(reply), ctx);
                            },
                            run};
  }

 private:
  struct Handler {
    std::function<Outcome(const google::protobuf::Message&, google::protobuf::Message&, const CallContext&)> fn;
    Run run = Run::on_worker;
  };
  const google::protobuf::ServiceDescriptor* interface_;
  std::unordered_map<std::string, Handler> handlers_;
};

}  // namespace urs::agent
