// Plug-ins that hosts must refuse, one per reason, selected by BAD_PLUGIN at compile time:
//   no_symbol: exports neither urs_plugin_abi nor urs_plugin_register;
//   wrong_abi: built for a plug-in ABI version no host has;
//   registers_nothing: a correct plug-in whose registration adds no agent type;
//   throws: a registration that throws (it adds a type the host has);
//   fails: a registration that adds a type, then returns non-zero.

#include "urs/agent/plugin.hpp"

#if BAD_PLUGIN_no_symbol
extern "C" URS_PLUGIN_EXPORT int not_a_plugin() { return 1; }
#elif BAD_PLUGIN_wrong_abi
extern "C" URS_PLUGIN_EXPORT const UrsPluginAbi urs_plugin_abi = {urs::agent::kPluginAbiVersion + 1000,
                                                                  GOOGLE_PROTOBUF_VERSION};
extern "C" URS_PLUGIN_EXPORT int urs_plugin_register(urs::agent::PluginRegistry&) { return 0; }
#elif BAD_PLUGIN_registers_nothing
URS_PLUGIN_ABI();
extern "C" URS_PLUGIN_EXPORT int urs_plugin_register(urs::agent::PluginRegistry&) { return 0; }
#elif BAD_PLUGIN_throws
URS_PLUGIN_ABI();
extern "C" URS_PLUGIN_EXPORT int urs_plugin_register(urs::agent::PluginRegistry& registry) {
  registry.add({"diagnostic", "", [](const YAML::Node&) { return std::shared_ptr<urs::agent::ServiceAgent>(); }, ""});
  return 0;
}
#elif BAD_PLUGIN_fails
URS_PLUGIN_ABI();
extern "C" URS_PLUGIN_EXPORT int urs_plugin_register(urs::agent::PluginRegistry& registry) {
  registry.add({"half", "", [](const YAML::Node&) { return std::shared_ptr<urs::agent::ServiceAgent>(); }, ""});
  return 3;
}
#endif
