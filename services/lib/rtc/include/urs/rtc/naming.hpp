#pragma once
// A client of the CORBA naming service (omniNames) with OpenRTM-aist's conventions: components
// are bound under "<host>.host_cxt/<instance>.rtc". Paths are written as name components joined
// by '/', each "id.kind" split at its LAST '.', so host names that contain dots keep them
// ("lab.example.org.host_cxt" is id "lab.example.org", kind "host_cxt").

#include <omniORB4/CORBA.h>

#include <mutex>
#include <omniORB4/Naming.hh>
#include <stdexcept>
#include <string>
#include <vector>

namespace urs::rtc {

class Orb;

// Any failure talking to the naming service or a name that is not bound; what() says which.
class NamingError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};
// The naming service itself cannot be reached (as opposed to a name that is not bound).
class NamingUnreachable : public NamingError {
 public:
  using NamingError::NamingError;
};

CosNaming::Name to_name(const std::string& path);  // throws std::invalid_argument on "" or "a//b"
std::string to_path(const CosNaming::Name& name);

// "<host>.host_cxt/<instance>.rtc"
std::string component_path(const std::string& host, const std::string& instance);

class NamingClient {
 public:
  struct Entry {
    std::string path;  // full path from the root
    std::string id;
    std::string kind;
    bool is_context = false;
  };

  // `host_port` is the naming service's "HOST:PORT"; nothing is contacted until the first call.
  // Thread-safe.
  NamingClient(const Orb& orb, const std::string& host_port);

  const std::string& address() const { return address_; }

  CORBA::Object_ptr resolve(const std::string& path);  // caller owns; NamingError if unbound
  // nil instead of NamingError when the name is not bound (other failures still throw).
  CORBA::Object_ptr try_resolve(const std::string& path);

  // Binds `object` at `path`, creating missing parent contexts. bind() throws NamingError if the
  // name is already bound; rebind() replaces what is there.
  void bind(const std::string& path, CORBA::Object_ptr object);
  void rebind(const std::string& path, CORBA::Object_ptr object);
  // Removes the binding; false if it was not bound.
  bool unbind(const std::string& path);

  // The bindings directly under `path` ("" is the root); NamingError if `path` is not a context.
  std::vector<Entry> list(const std::string& path = "");
  // Every object binding under `path`, depth first (contexts are descended, not returned).
  std::vector<Entry> list_objects(const std::string& path = "");

 private:
  CosNaming::NamingContext_ptr root();
  CosNaming::NamingContext_ptr context_at(const std::string& path);  // caller owns
  void bind_with_parents(const std::string& path, CORBA::Object_ptr object, bool replace);

  const Orb& orb_;
  std::string address_;
  std::mutex root_mutex_;  // one client may be shared by threads
  CosNaming::NamingContext_var root_;
};

}  // namespace urs::rtc
