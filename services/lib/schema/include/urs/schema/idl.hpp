#pragma once
// Loading an IDL file at run time, with no rebuild: the IDL is translated by omniidl and the
// Planet back-end (idl/omniidl_planet), exactly as the build does, then parsed with
// google::protobuf::compiler::Importer.
//
// Tools, compiled-in defaults overridable by environment variables (read at each call):
//   URS_OMNIIDL               the omniidl executable (default: the one found at configure time)
//   URS_OMNIIDL_BACKEND_DIR   folder of planet_proto.py (default: share/urslink/idl/omniidl_planet of
//                             the installed package, found relative to the installed library;
//                             idl/omniidl_planet of the sources for the library of a build tree)

#include <string>
#include <vector>

namespace urs::schema {

struct IdlLoad {
  // Serialized google.protobuf.FileDescriptorSet: the IDL file's schema and everything it imports
  // (schemas of #included IDL files, urs_options.proto, descriptor.proto), dependencies first.
  // Ready for SchemaPool::add_descriptor_set().
  std::string descriptor_set;
  // Full Protobuf names of the services (IDL interfaces) declared in the IDL file itself.
  std::vector<std::string> services;
  // "" on success; otherwise what failed, with omniidl's "<file>:<line>: ..." messages.
  std::string error;

  bool ok() const { return error.empty(); }
};

// Translates `idl_path` (and the files it #includes, found in its own folder and include_dirs).
// Blocking: runs omniidl as a child process (typically 0.1-0.5 s) in a private temporary folder,
// removed before returning. Thread-safe. Never throws on bad input.
IdlLoad load_idl(const std::string& idl_path, const std::vector<std::string>& include_dirs = {});

}  // namespace urs::schema
