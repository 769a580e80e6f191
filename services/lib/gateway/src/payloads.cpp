#include "urs/gateway/payloads.hpp"

#include <google/protobuf/util/json_util.h>

namespace urs::gateway {

namespace gp = google::protobuf;

gp::Value json_value(const std::string& json) {
  gp::Value value;
  if (!gp::util::JsonStringToMessage(json, &value).ok()) value.set_null_value(gp::NULL_VALUE);
  return value;
}

std::string PayloadDecoder::decode_json(const std::string& type, const std::string& payload) const {
  return schema::payload_to_json(&pool_, type, payload);
}

gp::Value PayloadDecoder::decode(const std::string& type, const std::string& payload) const {
  return json_value(decode_json(type, payload));
}

}  // namespace urs::gateway
