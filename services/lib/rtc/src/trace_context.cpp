#include "urs/rtc/trace_context.hpp"

#include <omniORB4/omniInterceptors.h>
// GIOP_S (the server side of a request, its service contexts) is declared in omniORB's internal
// headers only; they are installed with libomniorb4-dev and need these two first (clang-format
// would sort them after GIOP_S.h, which then does not compile).
// clang-format off
#include <omniORB4/internal/giopStream.h>
#include <omniORB4/internal/giopStrand.h>
#include <omniORB4/internal/GIOP_S.h>
// clang-format on

#include <mutex>
#include <string_view>

namespace urs::rtc {
namespace {

// Set by the receiving interceptor on the thread that will run the upcall, for every request
// (so nothing of a previous request lingers).
thread_local std::optional<util::TraceContext> g_incoming;

CORBA::Boolean on_receive(omni::omniInterceptors::serverReceiveRequest_T::info_T& info) {
  g_incoming.reset();
  const IOP::ServiceContextList& contexts = info.giop_s.service_contexts();
  for (CORBA::ULong i = 0; i < contexts.length(); ++i) {
    if (contexts[i].context_id != kTraceServiceContext) continue;
    const auto& data = contexts[i].context_data;
    if (data.length() > util::kMaxTraceparentBytes) break;  // refused before it is copied
    g_incoming =
        util::TraceContext::parse(std::string_view(reinterpret_cast<const char*>(data.get_buffer()), data.length()));
    break;
  }
  return true;
}

CORBA::Boolean on_send(omni::omniInterceptors::clientSendRequest_T::info_T& info) {
  const std::string traceparent = util::outgoing_trace().traceparent();
  const CORBA::ULong n = info.service_contexts.length();
  info.service_contexts.length(n + 1);
  IOP::ServiceContext& context = info.service_contexts[n];
  context.context_id = kTraceServiceContext;
  context.context_data.length(static_cast<CORBA::ULong>(traceparent.size()));
  for (size_t i = 0; i < traceparent.size(); ++i) {
    context.context_data[static_cast<CORBA::ULong>(i)] = static_cast<CORBA::Octet>(traceparent[i]);
  }
  return true;
}

}  // namespace

void install_trace_interceptors() {
  static std::once_flag once;
  std::call_once(once, [] {
    omniORB::getInterceptors()->serverReceiveRequest.add(on_receive);
    omniORB::getInterceptors()->clientSendRequest.add(on_send);
  });
}

std::optional<util::TraceContext> incoming_trace() { return g_incoming; }

}  // namespace urs::rtc
