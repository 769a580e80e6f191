#include "urs/schema/interface_catalog.hpp"

#include <stdexcept>

namespace urs::schema {

extern const unsigned char kCompiledInterfaces[];
extern const std::size_t kCompiledInterfacesSize;

namespace gp = google::protobuf;

std::string scoped_name(const gp::ServiceDescriptor& interface) {
  std::string name = interface.full_name();
  for (std::size_t at = name.find('.'); at != std::string::npos; at = name.find('.', at + 2)) name.replace(at, 1, "::");
  return name;
}

InterfaceCatalog::InterfaceCatalog() {
  auto built_in = std::make_unique<SchemaPool>();
  const std::string error = built_in->add_descriptor_set(
      std::string(reinterpret_cast<const char*>(kCompiledInterfaces), kCompiledInterfacesSize));
  if (!error.empty()) throw std::logic_error("built-in interfaces: " + error);
  pools_.push_back(std::move(built_in));
}

InterfaceCatalog::~InterfaceCatalog() = default;

std::vector<std::string> InterfaceCatalog::load_idl(const std::string& path,
                                                    const std::vector<std::string>& include_dirs) {
  const IdlLoad loaded = schema::load_idl(path, include_dirs);
  if (!loaded.ok()) throw std::runtime_error(loaded.error);
  auto pool = std::make_unique<SchemaPool>();
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

}  // namespace urs::schema
