#include "urs/planet/reply.hpp"

#include <utility>

namespace urs::planet {

Frame reply_frame(uint64_t call_id, CallResult&& result) {
  Frame frame;
  Reply& reply = *frame.mutable_reply();
  reply.set_call_id(call_id);
  reply.set_status(result.status);
  reply.set_message(std::move(result.message));
  reply.set_payload(std::move(result.payload));
  reply.set_exception_type(std::move(result.exception_type));
  return frame;
}

CallResult result_of(Reply&& reply) {
  CallResult result;
  result.status = reply.status();
  result.message = std::move(*reply.mutable_message());
  result.payload = std::move(*reply.mutable_payload());
  result.exception_type = std::move(*reply.mutable_exception_type());
  return result;
}

}  // namespace urs::planet
