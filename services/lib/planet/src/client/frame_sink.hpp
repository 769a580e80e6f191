#pragma once
// The open connection to the server as the client's components see it: where their frames go.
// The connection (client/connection.hpp) implements it; tests use a recording fake.

#include "planet.pb.h"

namespace urs::planet::detail {

class FrameSink {
 public:
  virtual ~FrameSink() = default;
  // Queues `frame` for the server; never blocks; thread-safe. False if the connection is closing:
  // the frame is then left as it was (to go out on the next connection, if its owner keeps it).
  virtual bool send(Frame&& frame) = 0;
};

}  // namespace urs::planet::detail
