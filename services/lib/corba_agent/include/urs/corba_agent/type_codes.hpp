#pragma once
// CORBA TypeCodes of the IDL types behind Planet messages (docs/idl-mapping.md), built from the
// descriptors and urs.options alone, with the IDL repository IDs the options record: what the
// DSI needs to receive arguments and to send results and user exceptions as static stubs expect.

#include <google/protobuf/descriptor.h>
#include <omniORB4/CORBA.h>

#include <map>
#include <set>

namespace urs::corba_agent {

// Not thread-safe: build what a servant needs once, up front.
class TypeCodes {
 public:
  explicit TypeCodes(CORBA::ORB_ptr orb) : orb_(CORBA::ORB::_duplicate(orb)) {}

  // The IDL type of one field (array dimensions included); the caller owns the reference.
  // Throws std::invalid_argument naming the field if its options do not describe an IDL type.
  CORBA::TypeCode_ptr field(const google::protobuf::FieldDescriptor& field);
  // A struct, exception or union message (recursive types use recursive TypeCodes).
  CORBA::TypeCode_ptr message(const google::protobuf::Descriptor& message);
  CORBA::TypeCode_ptr enumeration(const google::protobuf::EnumDescriptor& enumeration);

 private:
  CORBA::ORB_var orb_;
  std::map<const google::protobuf::Descriptor*, CORBA::TypeCode_var> messages_;
  std::set<const google::protobuf::Descriptor*> building_;  // for recursive types
};

}  // namespace urs::corba_agent
