#pragma once
// CDR <-> Protobuf for the messages the Planet translator generates from IDL (docs/idl-mapping.md),
// driven only by their descriptors and urs.options: a struct, exception or union is its IDL value;
// a Request is the in and inout arguments, a Reply the result then the out and inout arguments,
// each in IDL declaration order (the order of a GIOP request or reply body).
//
// Writing checks what IDL imposes and Protobuf does not (short, unsigned short and octet ranges,
// a char or wchar being one character, string and sequence bounds, array sizes, declared enum
// values, a union's branch matching its discriminator, no NUL inside a string) and throws
// ConversionError naming the field. Reading checks bounds and enum values the same way; input
// that ends early throws CORBA::MARSHAL (from the stream).
//
// Strings are carried as bytes: the Protobuf string's UTF-8 goes out unchanged in the stream's
// native char code set, as the static stubs pass char* through; a bound counts those bytes.
// char is one ISO 8859-1 character (one byte on the wire, UTF-8 in Protobuf); wchar and
// wstring convert between UTF-8 and the stream's wide code set (the stream must have one).

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <omniORB4/CORBA.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace urs::corba_agent {

// A value one side can hold and the other cannot; what() is "<path>: <reason>", the path naming
// the message type, then fields and element indexes ("URC.Marker.corners[4]: ...").
class ConversionError : public std::runtime_error {
 public:
  ConversionError(std::string path, std::string reason);
  const std::string& path() const { return path_; }
  const std::string& reason() const { return reason_; }
  // The same error one level further out ("<outer>.<path>" or "<outer><path>" for an index).
  ConversionError within(const std::string& outer) const;

 private:
  std::string path_;
  std::string reason_;
};

class CdrCodec {
 public:
  // Prepares every message type reachable from `roots` (fields, wrappers, nested types). Throws
  // std::invalid_argument naming the field if a field lacks idl_type or has one the mapping does
  // not write. Thread-safe once built: the plans are read-only.
  explicit CdrCodec(const std::vector<const google::protobuf::Descriptor*>& roots);
  ~CdrCodec();
  CdrCodec(const CdrCodec&) = delete;
  CdrCodec& operator=(const CdrCodec&) = delete;

  // The whole message (see the top of this file). Throws std::invalid_argument for a message type
  // not reachable from the roots.
  void write(cdrStream& stream, const google::protobuf::Message& message) const;
  void read(cdrStream& stream, google::protobuf::Message& message) const;
  // One field: one argument of a Request/Reply, one member of a struct.
  void write_field(cdrStream& stream, const google::protobuf::Message& message,
                   const google::protobuf::FieldDescriptor& field) const;
  void read_field(cdrStream& stream, google::protobuf::Message& message,
                  const google::protobuf::FieldDescriptor& field) const;

  struct Plans;  // per field and per message, built by the constructor

 private:
  std::unique_ptr<Plans> plans_;
};

}  // namespace urs::corba_agent
