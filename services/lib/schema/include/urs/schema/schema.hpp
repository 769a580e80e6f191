#pragma once
// Run-time interface descriptions (the Planet schema generated from IDL, docs/idl-mapping.md):
// descriptor sets to send, a pool of descriptions received at run time, dynamic messages, the
// urs.options custom options, JSON (json.hpp) and loading an IDL file without a rebuild (idl.hpp).
//
// Nothing here throws on bad input: functions return an error message (empty = ok) or nullptr.
// std::bad_alloc may propagate.

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/message.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "urs/schema/idl.hpp"
#include "urs/schema/json.hpp"

namespace urs::schema {

// Serialized google.protobuf.FileDescriptorSet holding `file` and all its transitive imports,
// dependencies first (each file once), without source locations. This is what a service sends to
// describe its interface. Thread-safe (descriptors are immutable).
std::string descriptor_set_for(const google::protobuf::FileDescriptor& file);

// A pool of interface descriptions received at run time (from a registry, a peer, or load_idl()).
//
// Threading: every member function may be called concurrently from any thread, including
// add_descriptor_set() while other threads look up or use descriptors and messages of the pool
// (the JSON functions included). Adds are serialised.
// Ownership: descriptors returned stay valid as long as the pool; messages from new_message()
// must be destroyed before the pool. Not copyable, not movable.
class SchemaPool {
 public:
  SchemaPool();
  ~SchemaPool();
  SchemaPool(const SchemaPool&) = delete;
  SchemaPool& operator=(const SchemaPool&) = delete;

  // Adds every file of a serialized FileDescriptorSet (in any order; imports may also be files
  // added earlier). A file already present with the same name and the same content is skipped;
  // the well-known google/protobuf/*.proto files are skipped whenever present (senders may run
  // other Protobuf versions). All or nothing: on error no file of the set is added, and the
  // returned message names the file (and element) at fault — a different file under a known name,
  // a name defined by another loaded file, an unresolved type or import, or unparsable bytes.
  // Returns "" on success.
  std::string add_descriptor_set(const std::string& bytes);

  // nullptr if unknown. Full names, e.g. "URS.Diagnostic", "URS.Diagnostic_add_Request",
  // "URS.Diagnostic.add".
  const google::protobuf::ServiceDescriptor* find_service(const std::string& full_name) const;
  const google::protobuf::Descriptor* find_message(const std::string& full_name) const;
  const google::protobuf::EnumDescriptor* find_enum(const std::string& full_name) const;
  const google::protobuf::MethodDescriptor* find_method(const std::string& full_name) const;

  // Full names of every service added so far, sorted.
  std::vector<std::string> service_names() const;

  // A new, empty message of `type` (a DynamicMessage; `type` may also come from another pool).
  // Never nullptr.
  std::unique_ptr<google::protobuf::Message> new_message(const google::protobuf::Descriptor& type) const;

 private:
  class Database;
  class Errors;

  std::unique_ptr<Database> database_;  // accepted files; the pool's fallback
  std::unique_ptr<Errors> errors_;      // errors of the pool's lazy builds
  std::unique_ptr<google::protobuf::DescriptorPool> pool_;
  mutable google::protobuf::DynamicMessageFactory factory_;
  std::mutex add_mutex_;  // serialises add_descriptor_set()
};

// A serialized message of type `type` (a Protobuf full name, e.g. an event's content type) as JSON
// text: decoded with the program's compiled type of that name, else with `pool`'s description (if
// `pool` is given); an "application/json" payload is JSON text already. An unknown type, or bytes
// that do not parse as one, give {"base64": "<the bytes>"}. Thread-safe; never throws on bad input.
std::string payload_to_json(const SchemaPool* pool, const std::string& type, const std::string& payload);

// --- urs.options (idl/urs_options.proto) ---------------------------------------------------------
// They work on descriptors from any pool. Absent options read as empty / false.

// Full Protobuf names of the exception messages the method declares (IDL raises), e.g. "URS.Failure".
std::vector<std::string> raises(const google::protobuf::MethodDescriptor& m);
// True for an IDL oneway operation (no reply is ever sent).
bool is_oneway(const google::protobuf::MethodDescriptor& m);
// CORBA repository IDs, e.g. "IDL:URS/Diagnostic:1.0" ("" if absent).
std::string repository_id(const google::protobuf::ServiceDescriptor& s);
std::string repository_id(const google::protobuf::MethodDescriptor& m);
std::string repository_id(const google::protobuf::Descriptor& d);
// True if the message stands for an IDL exception.
bool is_exception(const google::protobuf::Descriptor& d);
// The operation as IDL declares it, from the options of its Request and Reply (parameter names,
// directions and IDL types in signature order, the result type, raises, oneway):
//   "double add(in double a, in double b)"
//   "void moveTo(in double x, in double y) raises (URC::InvalidTarget, URC::NotReady)"
//   "oneway void notify(in string topic, in string text)"
// An attribute's accessors read "readonly attribute unsigned long speed" (_get_ without _set_)
// or "attribute string name" (_get_ of a settable one) and "" for _set_ (the attribute line covers
// it). Fields without urs.options (a schema not generated from IDL) show their Protobuf type and
// count as in (Request) or out (Reply) parameters.
std::string idl_signature(const google::protobuf::MethodDescriptor& m);

}  // namespace urs::schema
