#pragma once
// One fully populated Frame of every body type, for round-trip tests.

#include <vector>

#include "planet.pb.h"

namespace urs::planet::testing {

inline std::vector<Frame> sample_frames() {
  std::vector<Frame> frames;
  auto add = [&frames]() -> Frame& { return frames.emplace_back(); };
  {
    Hello& m = *add().mutable_hello();
    m.set_version(1);
    m.set_token("s3cret");
    m.set_peer_name("sam@robot1");
    m.set_role(SAM);
    m.set_session_secret("0123456789abcdef");
  }
  {
    Welcome& m = *add().mutable_welcome();
    m.set_version(1);
    m.set_space("kr");
    m.set_server_instance("feedface");
    m.set_heartbeat_interval_ms(1000);
    m.set_heartbeat_timeout_ms(3000);
    m.set_max_message_bytes(64ull << 20);
    m.set_chunk_bytes(64u << 10);
  }
  {
    Refused& m = *add().mutable_refused();
    m.set_status(UNAUTHENTICATED);
    m.set_reason("wrong token");
  }
  {
    Request& m = *add().mutable_request();
    m.set_call_id(42);
    m.set_service("robot1.navigation");
    m.set_operation("moveTo");
    m.set_payload(std::string("\x08\x01\x10\x02\x00\xff", 6));
    m.set_deadline_ms(2500);
    m.set_oneway(true);
  }
  {
    Reply& m = *add().mutable_reply();
    m.set_call_id(42);
    m.set_status(USER_EXCEPTION);
    m.set_message("blocked");
    m.set_payload("exception bytes");
    m.set_exception_type("urs.urc.Navigation.Blocked");
  }
  {
    Publish& m = *add().mutable_publish();
    m.set_publish_id(7);
    m.set_topic("kr/robot1/arrived");
    m.set_payload("{\"x\":1}");
    m.set_content_type("application/json");
  }
  {
    PublishAck& m = *add().mutable_publish_ack();
    m.set_publish_id(7);
    m.set_seq(1001);
    m.set_status(OK);
    m.set_message("stored");
  }
  {
    Subscribe& m = *add().mutable_subscribe();
    m.set_subscription_id(3);
    m.set_pattern("kr/*/arrived");
    m.set_resume_after_seq(999);
  }
  {
    SubscribeAck& m = *add().mutable_subscribe_ack();
    m.set_subscription_id(3);
    m.set_status(OK);
    m.set_message("ok");
    m.set_oldest_retained_seq(500);
    m.set_last_seq(1001);
  }
  add().mutable_unsubscribe()->set_subscription_id(3);
  {
    Event& m = *add().mutable_event();
    m.set_subscription_id(3);
    m.set_seq(1001);
    m.set_topic("kr/robot1/arrived");
    m.set_payload("{\"x\":1}");
    m.set_content_type("application/json");
    m.set_source("sam@robot1");
    m.set_time_unix_ns(1700000000123456789);
  }
  add().mutable_ping()->set_nonce(0xfffffffffffull);
  add().mutable_pong()->set_nonce(0xfffffffffffull);
  {
    Chunk& m = *add().mutable_chunk();
    m.set_message_id(9);
    m.set_total_bytes(3);
    m.set_data("abc");
    m.set_last(true);
    m.set_offset(0);
  }
  {
    Goodbye& m = *add().mutable_goodbye();
    m.set_status(UNAVAILABLE);
    m.set_reason("server shutting down");
  }
  return frames;
}

}  // namespace urs::planet::testing
