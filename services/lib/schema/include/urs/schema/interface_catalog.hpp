#pragma once
// The interfaces a bridge can carry, as Planet descriptions generated from IDL: those of the IDL
// it was built with (urs::idl) and those of IDL files loaded at run time (load_idl, no rebuild).
// Each source is a pool of its own, so a loaded file may redefine a built-in one's names.

#include <google/protobuf/descriptor.h>

#include <memory>
#include <string>
#include <vector>

#include "urs/schema/schema.hpp"

namespace urs::schema {

class InterfaceCatalog {
 public:
  InterfaceCatalog();  // the built-in interfaces
  ~InterfaceCatalog();

  // Translates and adds an IDL file (interfaces, or only data types for data ports); returns the
  // interfaces it declares (Protobuf full names).
  // Throws std::runtime_error with omniidl's messages on failure. Not concurrent with lookups.
  std::vector<std::string> load_idl(const std::string& path, const std::vector<std::string>& include_dirs);

  // An interface by the CORBA repository ID of an object ("IDL:URC/Navigation:1.0"); else by the
  // RT port's type_name: the IDL scoped name ("URC::Navigation") or, if only one interface has it,
  // the bare name ("Navigation"). Loaded files are searched before the built-in ones. nullptr if
  // none fits.
  const google::protobuf::ServiceDescriptor* find_interface(const std::string& repository_id,
                                                            const std::string& type_name) const;
  // A message type by Protobuf full name ("URC.Pose2D"); nullptr if unknown.
  const google::protobuf::Descriptor* find_message(const std::string& full_name) const;
  // Every interface's IDL scoped name, for messages.
  std::vector<std::string> interface_names() const;

 private:
  std::vector<std::unique_ptr<SchemaPool>> pools_;  // loaded files first, the built-in set last
};

// "URC::Navigation" for the Protobuf service URC.Navigation.
std::string scoped_name(const google::protobuf::ServiceDescriptor& interface);

}  // namespace urs::schema
