#pragma once
// The control plane's exceptions: one base and the few kinds a caller tells apart. The call path
// never throws; it returns typed outcomes (urs/call/call.hpp). A message names the entity, quotes
// the value and says what to do.
//
//   ConfigError   a flag, file or setting that cannot be used: fix it and start again
//   ProtocolError a peer broke the protocol or what was agreed with it (a malformed or forbidden
//                 answer): not worth retrying as is
//   NotFound      what was asked for does not exist (a service, an interface, a connection)
//   Unavailable   cannot be had now (a peer unreachable, a link not joined yet, shutting down):
//                 trying again later may work

#include <stdexcept>

namespace urs::util {

class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

class ConfigError : public Error {
 public:
  using Error::Error;
};

class ProtocolError : public Error {
 public:
  using Error::Error;
};

class NotFound : public Error {
 public:
  using Error::Error;
};

class Unavailable : public Error {
 public:
  using Error::Error;
};

}  // namespace urs::util
