#pragma once
// The client's calls in flight: those queued until a connection is open, and those sent and
// waiting for their Reply, each under its deadline.
//
// - A call goes out at once when a session is open and nothing is queued before it; else it waits
//   in order, counted in the QueueBudget (refused with UNAVAILABLE when no session is open and the
//   budget is full).
// - Deadlines: a call given one fails with DEADLINE_EXCEEDED when it passes (queueing included),
//   and what is left of it travels in the request. A call without one waits at most
//   queue_timeout for a connection (then UNAVAILABLE); once sent, the server bounds it.
// - At most once: when the session closes, calls already sent fail with UNAVAILABLE "connection to
//   server lost" and are never resent; queued calls wait for the next session.
//
// Threading: thread-safe. Handlers are never run under the lock: they are appended to the caller's
// Deferred, except on a deadline (run on the io_context's thread). Deadline timers run on `io`,
// which must outlive this table.

#include <asio.hpp>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "client/deferred.hpp"
#include "client/frame_sink.hpp"
#include "client/queue_budget.hpp"

namespace urs::planet::detail {

class PendingCalls {
 public:
  // `target` ("host:port") names the server in failures.
  PendingCalls(asio::io_context& io, std::string target, std::chrono::milliseconds queue_timeout, QueueBudget& budget);
  ~PendingCalls();
  PendingCalls(const PendingCalls&) = delete;
  PendingCalls& operator=(const PendingCalls&) = delete;

  // Registers `request` (its call_id is set here) and sends or queues it, see above; `first` sends
  // it ahead of the queue while a session is being restored (a re-registration). `deadline` 0:
  // none. An empty handler: a oneway, forgotten once sent. False if refused (the handler, if any,
  // gets the refusal in `out`).
  bool start(Request request, std::chrono::milliseconds deadline, ReplyHandler handler, Deferred& out,
             bool first = false);

  // A session opened on `sink`, whose server accepts messages up to `send_limit` bytes. Calls
  // started with `first` go out at once; the others keep waiting until flush().
  void open(std::shared_ptr<FrameSink> sink, uint64_t send_limit);
  // Sends the queued calls in order; from now on new calls go out at once.
  void flush(Deferred& out);
  // The session closed: sent calls fail (at most once), queued ones wait for the next session.
  void detach(Deferred& out);

  // A Reply from the server: completes its call; a late or unknown one is ignored.
  void on_reply(Reply&& reply, Deferred& out);

  // Fails every call with UNAVAILABLE `message` and refuses later ones with it.
  void close(const std::string& message, Deferred& out);

  size_t size() const;  // calls queued or waiting for a reply

 private:
  struct Call {
    Request request;       // moved out once sent
    std::string label;     // "service.operation"
    ReplyHandler handler;  // empty for oneways
    std::unique_ptr<asio::steady_timer> timer;
    std::chrono::steady_clock::time_point expires;
    std::chrono::milliseconds deadline{0};  // 0: none given, the server's applies once sent
    bool sent = false;
  };
  enum class Sent { kOut, kDropped, kKept };

  // With mutex_ held: hands call `id` to the sink. kKept: the connection is closing, the call
  // stays for the next one; kDropped: too large for the server, failed with PAYLOAD_TOO_LARGE.
  Sent send_locked(std::map<uint64_t, Call>::iterator it, Deferred& out);
  void on_deadline(uint64_t id);

  asio::io_context& io_;
  const std::string target_;
  const std::chrono::milliseconds queue_timeout_;
  QueueBudget& budget_;

  mutable std::mutex mutex_;
  std::shared_ptr<FrameSink> sink_;  // null: no session
  bool restoring_ = false;           // a session is open, flush() has not run yet
  uint64_t send_limit_ = UINT64_MAX;
  bool closed_ = false;
  std::string closed_message_;
  uint64_t next_id_ = 1;
  std::map<uint64_t, Call> calls_;  // queued and sent
  std::deque<uint64_t> queue_;      // ids not yet sent, in order; each holds a budget place
};

}  // namespace urs::planet::detail
