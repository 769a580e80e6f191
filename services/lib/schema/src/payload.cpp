#include <google/protobuf/struct.pb.h>
#include <google/protobuf/util/json_util.h>

#include <memory>

#include "urs/schema/schema.hpp"
#include "urs/util/json_text.hpp"

namespace urs::schema {

namespace gp = google::protobuf;

std::string payload_to_json(const SchemaPool* pool, const std::string& type, const std::string& payload) {
  if (type == "application/json") {
    gp::Value value;
    if (payload.empty()) return "null";
    if (gp::util::JsonStringToMessage(payload, &value).ok()) return payload;
  } else if (!type.empty()) {
    std::unique_ptr<gp::Message> message;
    if (const auto* compiled = gp::DescriptorPool::generated_pool()->FindMessageTypeByName(type)) {
      if (const gp::Message* prototype = gp::MessageFactory::generated_factory()->GetPrototype(compiled)) {
        message.reset(prototype->New());
      }
    }
    if (!message && pool != nullptr) {
      if (const gp::Descriptor* described = pool->find_message(type)) message = pool->new_message(*described);
    }
    std::string json;
    if (message && message->ParseFromString(payload) && message_to_json(*message, json).empty()) return json;
  }
  return "{\"base64\":" + util::json_string(util::base64(payload)) + "}";
}

}  // namespace urs::schema
