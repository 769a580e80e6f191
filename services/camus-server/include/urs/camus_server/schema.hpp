#pragma once
// One registered interface (a Protobuf service) and the pool that describes it, on top of
// urs::schema (SchemaPool, json_to_message, message_to_json, descriptor_set_for).
//
// Every registration gets its own pool, so two providers of different versions of an interface
// (or of a file with the same name) never clash.

#include <google/protobuf/descriptor.h>

#include <memory>
#include <string>

#include "urs/camus_server/result.hpp"
#include "urs/schema/schema.hpp"

namespace urs::camus_server {

// Serialized google.protobuf.FileDescriptorSet with `file` and all its imports, imports first.
inline std::string descriptor_set_for(const google::protobuf::FileDescriptor& file) {
  return schema::descriptor_set_for(file);
}

// Immutable; thread-safe.
class InterfaceSchema {
 public:
  // BAD_ARGUMENTS with the reason if `descriptor_set` does not load or lacks `interface`.
  static Result<std::shared_ptr<const InterfaceSchema>> build(const std::string& interface,
                                                              const std::string& descriptor_set);
  InterfaceSchema(const InterfaceSchema&) = delete;
  InterfaceSchema& operator=(const InterfaceSchema&) = delete;

  const std::string& interface_name() const { return interface_; }
  const std::string& descriptor_set() const { return descriptor_set_; }
  const google::protobuf::ServiceDescriptor& service() const { return *service_; }
  // nullptr if the pool has no such message type.
  const google::protobuf::Descriptor* find_message(const std::string& full_name) const;

  // JSON text (Protobuf's JSON mapping) -> serialized message of `type`; BAD_ARGUMENTS naming the
  // type and the offending field when it does not fit.
  Result<std::string> json_to_payload(const google::protobuf::Descriptor& type, const std::string& json) const;
  // Serialized message of `type` -> JSON text with the IDL (.proto) field names and default values.
  Result<std::string> payload_to_json(const google::protobuf::Descriptor& type, const std::string& payload) const;

 private:
  InterfaceSchema() = default;

  std::string interface_;
  std::string descriptor_set_;
  std::unique_ptr<schema::SchemaPool> pool_;
  const google::protobuf::ServiceDescriptor* service_ = nullptr;
};

}  // namespace urs::camus_server
