#include "urs/camus_server/schema.hpp"

namespace urs::camus_server {

namespace gp = google::protobuf;

Result<std::shared_ptr<const InterfaceSchema>> InterfaceSchema::build(const std::string& interface,
                                                                      const std::string& descriptor_set) {
  std::shared_ptr<InterfaceSchema> out(new InterfaceSchema());
  out->interface_ = interface;
  out->descriptor_set_ = descriptor_set;
  out->pool_ = std::make_unique<schema::SchemaPool>();
  if (auto error = out->pool_->add_descriptor_set(descriptor_set); !error.empty()) {
    return make_error(planet::BAD_ARGUMENTS, "descriptor_set for " + interface + " does not load: " + error);
  }
  out->service_ = out->pool_->find_service(interface);
  if (out->service_ == nullptr) {
    return make_error(planet::BAD_ARGUMENTS,
                      "descriptor_set does not describe interface " + interface + ": it does not define that service");
  }
  return std::shared_ptr<const InterfaceSchema>(std::move(out));
}

const gp::Descriptor* InterfaceSchema::find_message(const std::string& full_name) const {
  return pool_->find_message(full_name);
}

Result<std::string> InterfaceSchema::json_to_payload(const gp::Descriptor& type, const std::string& json) const {
  auto message = pool_->new_message(type);
  if (auto error = schema::json_to_message(json, *message); !error.empty()) {
    return make_error(planet::BAD_ARGUMENTS, error);
  }
  return message->SerializeAsString();
}

Result<std::string> InterfaceSchema::payload_to_json(const gp::Descriptor& type, const std::string& payload) const {
  auto message = pool_->new_message(type);
  if (!message->ParseFromString(payload)) {
    return make_error(planet::BAD_ARGUMENTS, "payload is not a valid " + type.full_name());
  }
  std::string json;
  if (auto error = schema::message_to_json(*message, json); !error.empty()) {
    return make_error(planet::INTERNAL, error);
  }
  return json;
}

}  // namespace urs::camus_server
