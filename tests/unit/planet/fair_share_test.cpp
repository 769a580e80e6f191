#include "urs/planet/fair_share.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <chrono>

#include "session_directory.hpp"

namespace urs::planet {
namespace {

using ::testing::HasSubstr;
using ::testing::UnorderedElementsAre;

FairShare::Limits calls(uint64_t total, uint64_t per_credential, uint64_t reserved) {
  return {total,
          per_credential,
          reserved,
          "max_pending_calls",
          "max_pending_calls_per_credential",
          "reserved_percent 20",
          "calls pending"};
}

const ShareHolder kMallory{"mallory", false};
const ShareHolder kViewer{"viewer", false};
const ShareHolder kSam{"sam-robot1", true};

TEST(FairShare, ACredentialIsRefusedOverItsOwnLimitNamingIt) {
  FairShare share(calls(100, 10, 20));
  for (int i = 0; i < 10; ++i) ASSERT_EQ(share.take(kMallory, 1), "") << i;
  EXPECT_EQ(share.take(kMallory, 1),
            "credential 'mallory' holds 10 calls pending (max_pending_calls_per_credential 10)");
  EXPECT_EQ(share.take(kViewer, 1), "");
  EXPECT_EQ(share.used_by("mallory"), 10u);
  EXPECT_EQ(share.used(), 11u);
  share.give(kMallory, 10);
  EXPECT_EQ(share.used_by("mallory"), 0u);
  EXPECT_EQ(share.take(kMallory, 1), "");
}

// The global limit refuses the credential over its fair share, never one within it; client
// credentials leave the reserve to privileged holders.
TEST(FairShare, AFullPoolRefusesOnlyTheCredentialOverItsFairShare) {
  FairShare share(calls(100, 100, 20));
  for (int i = 0; i < 80; ++i) ASSERT_EQ(share.take(kMallory, 1), "") << i;
  EXPECT_TRUE(share.pool_full(false));
  EXPECT_FALSE(share.pool_full(true));
  const std::string refusal = share.take(kMallory, 1);
  EXPECT_EQ(refusal,
            "the server holds 80 calls pending for client credentials, its limit (max_pending_calls 100 less the 20 "
            "kept for sam and operator sessions, reserved_percent 20); credential 'mallory' holds 80, over its fair "
            "share of 80; retry later");
  // Another client within its fair share (80 / 2) goes on, past the pool.
  for (int i = 0; i < 40; ++i) ASSERT_EQ(share.take(kViewer, 1), "") << i;
  EXPECT_THAT(share.take(kViewer, 1), HasSubstr("credential 'viewer' holds 40, over its fair share of 40"));
  // A privileged holder has the reserve (and its fair share of the whole beyond).
  EXPECT_EQ(share.take(kSam, 1), "");
  EXPECT_EQ(share.used(), 121u);
  EXPECT_EQ(share.used_by_clients(), 120u);
  // Once the attacker gives back, the pool has room again for it.
  share.give(kMallory, 80);
  EXPECT_EQ(share.take(kMallory, 1), "");
}

TEST(FairShare, AccountsCountWithoutLookupsAndHeaviestNamesTheLargestClient) {
  FairShare share(calls(1000, 500, 100));
  auto mallory = share.account(kMallory);
  auto viewer = share.account(kViewer);
  auto sam = share.account(kSam);
  EXPECT_EQ(share.take(*mallory, 300), "");
  EXPECT_EQ(share.take(*viewer, 10), "");
  EXPECT_EQ(share.take(*sam, 400), "");
  EXPECT_EQ(share.heaviest(), "mallory");  // a client first, even below a privileged holder
  EXPECT_THAT(share.take(*mallory, 201), HasSubstr("(max_pending_calls_per_credential 500)"));
  share.force(*mallory, 250);  // what cannot be refused is counted all the same
  EXPECT_EQ(mallory->used(), 550u);
  share.give(*mallory, 550);
  share.give(*viewer, 10);
  EXPECT_EQ(share.heaviest(), "sam-robot1");
  share.give(*sam, 400);
  EXPECT_EQ(share.heaviest(), "");
  EXPECT_EQ(share.used(), 0u);
}

TEST(FairShare, LimitsAreValidated) {
  EXPECT_THROW(FairShare(calls(0, 0, 0)), std::invalid_argument);
  EXPECT_THROW(FairShare(calls(10, 5, 10)), std::invalid_argument);
}

// Churn by one credential evicts only its own keys while another stays within its share.
TEST(FairQueue, ACredentialOverItsShareEvictsItsOwnOldest) {
  FairQueue queue(calls(10, 4, 2));
  EXPECT_TRUE(queue.add(1, kViewer).empty());
  std::vector<uint64_t> evicted;
  for (uint64_t key = 100; key < 200; ++key) {
    for (uint64_t gone : queue.add(key, kMallory)) evicted.push_back(gone);
  }
  EXPECT_TRUE(queue.holds(1));
  EXPECT_EQ(queue.held_by("mallory"), 4u);
  EXPECT_EQ(evicted.size(), 96u);
  EXPECT_EQ(evicted.front(), 100u);
  EXPECT_FALSE(queue.holds(195));
  EXPECT_TRUE(queue.holds(199));
}

TEST(FairQueue, TooManyTogetherEvictTheHeaviestCredentialsOldest) {
  FairQueue queue(calls(6, 6, 0));
  EXPECT_TRUE(queue.add(1, kViewer).empty());
  for (uint64_t key = 10; key < 15; ++key) EXPECT_TRUE(queue.add(key, kMallory).empty());
  // The seventh key: mallory (5 of 6) is over its fair share (3): it loses its oldest.
  EXPECT_THAT(queue.add(15, kMallory), UnorderedElementsAre(10u));
  EXPECT_THAT(queue.add(2, kViewer), UnorderedElementsAre(11u));
  EXPECT_TRUE(queue.holds(1));
  EXPECT_TRUE(queue.holds(2));
  EXPECT_EQ(queue.oldest(), std::optional<uint64_t>(1));
  queue.touch(1);
  EXPECT_EQ(queue.oldest(), std::optional<uint64_t>(12));
  EXPECT_TRUE(queue.remove(12));
  EXPECT_FALSE(queue.remove(12));
  EXPECT_EQ(queue.size(), 5u);
}

// A session object for the directory (never used beyond its address).
class NullSession : public Session {
 public:
  uint64_t id() const override { return 0; }
  const Hello& hello() const override { return hello_; }
  const Identity& identity() const override { return identity_; }
  std::string remote_address() const override { return "?"; }
  bool send(Frame) override { return false; }
  void close(Status, const std::string&) override {}

 private:
  Hello hello_;
  Identity identity_;
};

FairShare::Limits retained(uint64_t total, uint64_t per_credential) {
  return {total,
          per_credential,
          0,
          "max_resumable_sessions",
          "max_resumable_sessions_per_credential",
          "reserved_percent 0",
          "resumable sessions"};
}

TEST(SessionDirectory, ChurnByOneCredentialNeverEvictsAnothersSession) {
  detail::SessionDirectory directory(std::chrono::minutes(10), retained(50, 10));
  auto victim_connection = std::make_shared<NullSession>();
  auto victim = directory.open("", kViewer, victim_connection);
  directory.closed(victim.session, victim_connection.get(), 7);
  for (int i = 0; i < 1000; ++i) {
    auto connection = std::make_shared<NullSession>();
    auto opened = directory.open("", kMallory, connection);
    directory.closed(opened.session, connection.get(), 0);
  }
  EXPECT_EQ(directory.retained(), 11u);
  auto again = std::make_shared<NullSession>();
  auto resumed = directory.open(victim.secret, kViewer, again);
  EXPECT_TRUE(resumed.resumed);
  EXPECT_EQ(resumed.session, victim.session);
}

TEST(SessionDirectory, AForgottenSessionLeavesWhatItReceivedForItsSuccessor) {
  detail::SessionDirectory directory(std::chrono::minutes(10), retained(50, 2));
  auto first_connection = std::make_shared<NullSession>();
  auto first = directory.open("", kViewer, first_connection);
  directory.closed(first.session, first_connection.get(), 42);
  for (int i = 0; i < 2; ++i) {  // the credential's own churn evicts its oldest
    auto connection = std::make_shared<NullSession>();
    auto opened = directory.open("", kViewer, connection);
    directory.closed(opened.session, connection.get(), 0);
  }
  EXPECT_EQ(directory.tombstones(), 1u);
  // Presented by another credential, the secret means nothing.
  auto stranger = directory.open(first.secret, kMallory, std::make_shared<NullSession>());
  EXPECT_FALSE(stranger.resumed);
  EXPECT_EQ(stranger.forgotten_session, 0u);
  auto back = directory.open(first.secret, kViewer, std::make_shared<NullSession>());
  EXPECT_FALSE(back.resumed);
  EXPECT_NE(back.session, first.session);
  EXPECT_EQ(back.forgotten_session, first.session);
  EXPECT_EQ(back.forgotten_publish_through, 42u);
  EXPECT_EQ(directory.tombstones(), 0u);  // used once
}

}  // namespace
}  // namespace urs::planet
