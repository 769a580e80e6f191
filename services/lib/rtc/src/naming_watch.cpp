#include "urs/rtc/naming_watch.hpp"

#include <algorithm>
#include <set>

namespace urs::rtc {

std::optional<ComponentBindings> read_component_bindings(NamingClient& naming, const Orb& orb,
                                                         const std::function<bool(const std::string&)>& watched,
                                                         const std::function<bool()>& stopping) {
  std::vector<NamingClient::Entry> entries = naming.list_objects();
  std::sort(entries.begin(), entries.end(),
            [](const NamingClient::Entry& a, const NamingClient::Entry& b) { return a.path < b.path; });
  ComponentBindings bound;
  std::set<std::string> iors;
  for (const NamingClient::Entry& entry : entries) {
    if (stopping && stopping()) return std::nullopt;
    if (entry.kind != "rtc" || !watched(entry.path)) continue;
    ComponentBinding binding;
    binding.object = naming.try_resolve(entry.path);
    if (CORBA::is_nil(binding.object)) continue;  // unbound since the listing
    binding.ior = orb.object_to_string(binding.object);
    if (!iors.insert(binding.ior).second) continue;  // a component bound under several names: once
    bound.emplace(entry.path, std::move(binding));
  }
  return bound;
}

}  // namespace urs::rtc
