#include "urs/bridge/interfaces.hpp"

#include <stdexcept>

namespace urs::bridge {

extern const unsigned char kCompiledInterfaces[];
extern const std::size_t kCompiledInterfacesSize;

namespace gp = google::protobuf;

std::string scoped_name(const gp::ServiceDescriptor& interface) {
  std::string name = interface.full_name();
  for (std::size_t at = name.find('.'); at != std::string::npos; at = name.find('.', at + 2)) name.replace(at, 1, "::");
  return name;
}

std::string ior_type_id(const std::string& ior) {
  if (ior.size() < 4 || ior.compare(0, 4, "IOR:") != 0 || ior.size() % 2 != 0) return "";
  std::string bytes;
  for (std::size_t i = 4; i + 1 < ior.size(); i += 2) {
    const std::string pair = ior.substr(i, 2);
    char* end = nullptr;
    const long value = std::strtol(pair.c_str(), &end, 16);
    if (end != pair.c_str() + 2) return "";
    bytes.push_back(static_cast<char>(value));
  }
  // CDR encapsulation: byte-order octet, padding to 4, then the type ID as a CDR string.
  if (bytes.size() < 8) return "";
  const bool little = bytes[0] != 0;
  uint32_t length = 0;
  for (int i = 0; i < 4; ++i) {
    const auto byte = static_cast<uint8_t>(bytes[4 + i]);
    length |= little ? uint32_t(byte) << (8 * i) : uint32_t(byte) << (8 * (3 - i));
  }
  if (length == 0 || 8 + length > bytes.size()) return "";
  return bytes.substr(8, length - 1);  // without the terminating NUL
}

InterfaceCatalog::InterfaceCatalog() {
  auto built_in = std::make_unique<schema::SchemaPool>();
  const std::string error = built_in->add_descriptor_set(
      std::string(reinterpret_cast<const char*>(kCompiledInterfaces), kCompiledInterfacesSize));
  if (!error.empty()) throw std::logic_error("built-in interfaces: " + error);
  pools_.push_back(std::move(built_in));
}

InterfaceCatalog::~InterfaceCatalog() = default;

std::vector<std::string> InterfaceCatalog::load_idl(const std::string& path,
                                                    const std::vector<std::string>& include_dirs) {
  const schema::IdlLoad loaded = schema::load_idl(path, include_dirs);
  if (!loaded.ok()) throw std::runtime_error(loaded.error);
  auto pool = std::make_unique<schema::SchemaPool>();
  const std::string error = pool->add_descriptor_set(loaded.descriptor_set);
  if (!error.empty()) throw std::runtime_error(path + ": " + error);
  pools_.insert(pools_.begin(), std::move(pool));
  return loaded.services;
}

const gp::ServiceDescriptor* InterfaceCatalog::find_interface(const std::string& repository_id,
                                                              const std::string& type_name) const {
  std::vector<const gp::ServiceDescriptor*> services;
  for (const auto& pool : pools_) {
    for (const auto& name : pool->service_names()) {
      if (const gp::ServiceDescriptor* service = pool->find_service(name)) services.push_back(service);
    }
  }
  if (!repository_id.empty()) {
    for (const auto* service : services) {
      if (schema::repository_id(*service) == repository_id) return service;
    }
  }
  if (type_name.empty()) return nullptr;
  for (const auto* service : services) {
    if (scoped_name(*service) == type_name) return service;
  }
  const gp::ServiceDescriptor* found = nullptr;
  for (const auto* service : services) {
    if (service->name() != type_name) continue;
    if (found != nullptr && found->full_name() != service->full_name()) return nullptr;  // ambiguous
    if (found == nullptr) found = service;
  }
  return found;
}

const gp::Descriptor* InterfaceCatalog::find_message(const std::string& full_name) const {
  for (const auto& pool : pools_) {
    if (const gp::Descriptor* type = pool->find_message(full_name)) return type;
  }
  return nullptr;
}

std::vector<std::string> InterfaceCatalog::interface_names() const {
  std::vector<std::string> names;
  for (const auto& pool : pools_) {
    for (const auto& name : pool->service_names()) {
      if (const gp::ServiceDescriptor* service = pool->find_service(name)) names.push_back(scoped_name(*service));
    }
  }
  return names;
}

}  // namespace urs::bridge
