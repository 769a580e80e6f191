#pragma once
// A call's result on the wire: the Reply frame that carries a CallResult, and back. Shared by the
// client (answers of its Responders, replies to its calls) and the server's router.

#include <cstdint>

#include "planet.pb.h"
#include "urs/planet/status.hpp"

namespace urs::planet {

// The Reply frame answering call `call_id` with `result`, and the result a Reply carries.
// Strings are moved, never copied (a reply may carry a 921,600-byte image).
Frame reply_frame(uint64_t call_id, CallResult&& result);
CallResult result_of(Reply&& reply);

}  // namespace urs::planet
