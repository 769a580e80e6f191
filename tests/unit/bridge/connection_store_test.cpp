// ConnectionStore: what the bridge keeps of its RTCs' connections survives a save and a load,
// a malformed entry is skipped without losing the others, and no path keeps nothing.

#include "urs/bridge/rt/connection_store.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace urs::bridge {
namespace {

class ConnectionStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("urs-store-" + std::to_string(getpid()) + "-" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }
  std::string file() const { return (dir_ / "connections.yaml").string(); }

  std::filesystem::path dir_;
};

SavedConnection consumer_connection() {
  return {"camus:diag",
          "diagnostic",
          "5f0c-1",
          "MyConsumer0.myservice0: \"quoted\"",
          false,
          {"IOR:0123abcd", ""},
          {{"port.connection.strictness", "best_effort"}, {"weird key: #", "a\nb"}}};
}

TEST_F(ConnectionStoreTest, WhatIsSavedIsLoadedBack) {
  ConnectionStore store(file());
  SavedConnection bridge_made{"bridge", "in0", "id-2", "urs-bridge.lab", true, {"IOR:ff", ""}, {}};
  store.save({consumer_connection(), bridge_made});
  const auto loaded = ConnectionStore(file()).load();
  ASSERT_EQ(loaded.size(), 2u);
  EXPECT_EQ(loaded[0], consumer_connection());
  EXPECT_EQ(loaded[1], bridge_made);
}

TEST_F(ConnectionStoreTest, TheSameConnectionsAreNotWrittenAgain) {
  ConnectionStore store(file());
  store.save({consumer_connection()});
  std::filesystem::remove(file());
  store.save({consumer_connection()});
  EXPECT_FALSE(std::filesystem::exists(file()));
  store.save({});
  EXPECT_TRUE(std::filesystem::exists(file()));
  EXPECT_TRUE(ConnectionStore(file()).load().empty());
}

TEST_F(ConnectionStoreTest, AMalformedEntryIsSkippedAndTheOthersKept) {
  std::ofstream(file()) << "connections:\n"
                           "  - {rtc: bridge, port: providers}\n"  // no id
                           "  - {rtc: bridge, port: providers, id: x, ports: {not: a list}}\n"
                           "  - {rtc: 'camus:tts', port: texttospeech, id: y, ports: ['IOR:1', '']}\n";
  const auto loaded = ConnectionStore(file()).load();
  ASSERT_EQ(loaded.size(), 1u);
  EXPECT_EQ(loaded[0].rtc, "camus:tts");
  EXPECT_EQ(loaded[0].ports, (std::vector<std::string>{"IOR:1", ""}));
}

TEST_F(ConnectionStoreTest, NotYamlOrMissingIsNothing) {
  EXPECT_TRUE(ConnectionStore(file()).load().empty());
  std::ofstream(file()) << "connections: [unclosed\n";
  EXPECT_TRUE(ConnectionStore(file()).load().empty());
}

TEST_F(ConnectionStoreTest, NoPathKeepsNothing) {
  ConnectionStore store("");
  store.save({consumer_connection()});
  EXPECT_TRUE(store.load().empty());
  EXPECT_TRUE(std::filesystem::is_empty(dir_));
}

}  // namespace
}  // namespace urs::bridge
