#include "rpc_registrations.hpp"

#include <fastdds/dds/publisher/DataWriter.hpp>

#include "Federation.h"

namespace urs::federation {

namespace fdds = eprosima::fastdds::dds;

void RpcRegistrations::retire(fdds::DataWriter* writer, const std::string& id, bool reply) {
  if (reply) {
    dds::CallReply key;
    key.request_id(id);
    writer->unregister_instance(&key, fdds::HANDLE_NIL);
  } else {
    dds::CallRequest key;
    key.request_id(id);
    writer->unregister_instance(&key, fdds::HANDLE_NIL);
  }
}

void RpcRegistrations::retire_later(fdds::DataWriter* writer, const std::string& id, bool reply,
                                    Clock::time_point until) {
  std::lock_guard lock(mutex_);
  const auto now = Clock::now();
  for (auto it = registered_.begin(); it != registered_.end();) {
    if (it->until > now) {
      ++it;
      continue;
    }
    retire(it->writer, it->request_id, it->reply);
    it = registered_.erase(it);
  }
  registered_.push_back({until, writer, id, reply});
}

void RpcRegistrations::retire_reply(const std::string& id) {
  std::lock_guard lock(mutex_);
  for (auto it = registered_.begin(); it != registered_.end(); ++it) {
    if (it->reply && it->request_id == id) {
      retire(it->writer, id, true);
      registered_.erase(it);
      return;
    }
  }
}

}  // namespace urs::federation
