#include "urs/bridge/rt/connection_store.hpp"

#include <spdlog/spdlog.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "urs/util/cli.hpp"

namespace urs::bridge {

bool SavedConnection::operator==(const SavedConnection& other) const {
  return rtc == other.rtc && port == other.port && id == other.id && name == other.name &&
         made_by_bridge == other.made_by_bridge && ports == other.ports && properties == other.properties;
}

bool describe_connection(const RTC::ConnectorProfile& profile, RTC::PortService_ptr ours, const std::string& rtc,
                         const std::string& port, bool made_by_bridge,
                         const std::function<std::string(CORBA::Object_ptr)>& peer_ior, SavedConnection& out) {
  out = SavedConnection{rtc, port, profile.connector_id.in(), profile.name.in(), made_by_bridge, {}, {}};
  bool peers = false;
  for (CORBA::ULong i = 0; i < profile.ports.length(); ++i) {
    const RTC::PortService_ptr each = profile.ports[i];
    if (CORBA::is_nil(each)) continue;
    bool mine = false;
    try {
      mine = each->_is_equivalent(ours);
    } catch (const CORBA::SystemException&) {
    }
    if (mine) {
      out.ports.emplace_back();
    } else {
      out.ports.push_back(peer_ior(each));
      peers = true;
    }
  }
  for (CORBA::ULong i = 0; i < profile.properties.length(); ++i) {
    const char* value = nullptr;
    if (!(profile.properties[i].value >>= value) || value == nullptr) continue;  // references, numbers
    if (std::string(value).rfind("IOR:", 0) == 0) continue;                      // published again on connecting
    out.properties[profile.properties[i].name.in()] = value;
  }
  return peers;
}

ConnectionStore::ConnectionStore(std::string path) : path_(std::move(path)) {}

std::vector<SavedConnection> ConnectionStore::load() const {
  std::vector<SavedConnection> loaded;
  if (path_.empty() || !std::filesystem::exists(path_)) return loaded;
  std::ifstream in(path_);
  std::stringstream text;
  text << in.rdbuf();
  written_ = text.str();
  YAML::Node root;
  try {
    root = YAML::Load(written_);
  } catch (const YAML::Exception& e) {
    spdlog::error("bridge: {} is not YAML ({}); no connection is restored from it", path_, e.what());
    return loaded;
  }
  const YAML::Node list = root["connections"];
  if (!list || !list.IsSequence()) return loaded;
  for (std::size_t i = 0; i < list.size(); ++i) {
    const YAML::Node entry = list[i];
    try {
      SavedConnection saved;
      saved.rtc = entry["rtc"].as<std::string>();
      saved.port = entry["port"].as<std::string>();
      saved.id = entry["id"].as<std::string>();
      saved.name = entry["name"].as<std::string>("");
      saved.made_by_bridge = entry["made_by_bridge"].as<bool>(false);
      for (const auto& port : entry["ports"]) saved.ports.push_back(port.as<std::string>());
      if (const YAML::Node properties = entry["properties"]) {
        for (const auto& property : properties) {
          saved.properties[property.first.as<std::string>()] = property.second.as<std::string>();
        }
      }
      if (saved.rtc.empty() || saved.port.empty() || saved.id.empty()) {
        throw std::invalid_argument("rtc, port and id are required");
      }
      loaded.push_back(std::move(saved));
    } catch (const std::exception& e) {  // YAML::Exception for a missing or mistyped key
      spdlog::error("bridge: {}: connections[{}] is skipped: {}", path_, i, e.what());
    }
  }
  return loaded;
}

void ConnectionStore::save(const std::vector<SavedConnection>& connections) {
  if (path_.empty()) return;
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "connections" << YAML::Value << YAML::BeginSeq;
  for (const auto& saved : connections) {
    out << YAML::BeginMap;
    out << YAML::Key << "rtc" << YAML::Value << YAML::DoubleQuoted << saved.rtc;
    out << YAML::Key << "port" << YAML::Value << YAML::DoubleQuoted << saved.port;
    out << YAML::Key << "id" << YAML::Value << YAML::DoubleQuoted << saved.id;
    out << YAML::Key << "name" << YAML::Value << YAML::DoubleQuoted << saved.name;
    out << YAML::Key << "made_by_bridge" << YAML::Value << saved.made_by_bridge;
    out << YAML::Key << "ports" << YAML::Value << YAML::BeginSeq;
    for (const auto& port : saved.ports) out << YAML::DoubleQuoted << port;
    out << YAML::EndSeq;
    out << YAML::Key << "properties" << YAML::Value << YAML::BeginMap;
    for (const auto& [name, value] : saved.properties) {
      out << YAML::Key << YAML::DoubleQuoted << name << YAML::Value << YAML::DoubleQuoted << value;
    }
    out << YAML::EndMap << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  const std::string text = std::string(out.c_str()) + "\n";
  if (text == written_) return;
  try {
    util::write_file_atomically(path_, text);
    written_ = text;
  } catch (const std::exception& e) {
    spdlog::error("bridge: the connections of its RTCs cannot be kept in {}: {}", path_, e.what());
  }
}

}  // namespace urs::bridge
