// The audit log of calls from other spaces: one JSON line per call, written when answered,
// rotated by size, never a payload or a reply's message.

#include "urs/bridge/dds/call_audit.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "urs/bridge/dds/call_authorization.hpp"

namespace urs::bridge {
namespace {

std::vector<std::string> lines_of(const std::string& path) {
  std::vector<std::string> lines;
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

class CallAuditTest : public ::testing::Test {
 protected:
  void SetUp() override { std::filesystem::create_directories(folder_); }
  void TearDown() override { std::filesystem::remove_all(folder_); }
  const std::string folder_ = ::testing::TempDir() + "call-audit-" + std::to_string(getpid());
  const std::string file_ = folder_ + "/calls.jsonl";
};

TEST(AuditLine, HoldsWhoWhatOutcomeAndDuration) {
  AuditEntry entry;
  entry.time = std::chrono::system_clock::time_point(std::chrono::microseconds(1795857615123456));
  entry.caller = {"kr", "dds:kr", federation::kVerifiedSpaceRole};
  entry.service = "rt.Diagnostic0";
  entry.operation = "ping";
  entry.status = call::Status::OK;
  entry.duration = std::chrono::microseconds(812);
  EXPECT_EQ(audit_line(entry),
            "{\"time\":\"2026-11-28T09:20:15.123456Z\",\"caller_space\":\"kr\",\"caller\":\"dds:kr\","
            "\"space_verified\":true,\"service\":\"rt.Diagnostic0\",\"operation\":\"ping\",\"oneway\":false,"
            "\"status\":\"OK\",\"duration_us\":812}");
  entry.caller.role = federation::kDeclaredSpaceRole;
  entry.caller.space = "k\"r";
  entry.status = call::Status::PERMISSION_DENIED;
  entry.refusal = "space k\"r may not call jp/rt.Diagnostic0";
  const std::string line = audit_line(entry);
  EXPECT_NE(line.find("\"caller_space\":\"k\\\"r\""), std::string::npos) << line;
  EXPECT_NE(line.find("\"space_verified\":false"), std::string::npos) << line;
  EXPECT_NE(line.find("\"status\":\"PERMISSION_DENIED\",\"reason\":\"space k\\\"r may not call"), std::string::npos)
      << line;
}

TEST(AuditLine, HoldsTheCallsTraceIdWhenItCameWithOne) {
  AuditEntry entry;
  entry.service = "rt.Diagnostic0";
  entry.operation = "ping";
  entry.trace_id = "4bf92f3577b34da6a3ce929d0e0e4736";
  entry.duration = std::chrono::microseconds(5);
  const std::string line = audit_line(entry);
  EXPECT_NE(line.find("\"status\":\"OK\",\"trace_id\":\"4bf92f3577b34da6a3ce929d0e0e4736\",\"duration_us\":5}"),
            std::string::npos)
      << line;
}

TEST_F(CallAuditTest, RecordsAnswersAndRefusalsWithoutPayloads) {
  auto audit = CallAudit::open({file_, 1u << 20, 2});
  call::Request request;
  request.service = "rt.Diagnostic0";
  request.operation = "ping";
  request.payload = "SECRET-PAYLOAD";
  request.caller = {"kr", "dds:kr", federation::kVerifiedSpaceRole};
  request.traceparent = "00-4bf92f3577b34da6a3ce929d0e0e4736-00f067aa0ba902b7-01";
  std::optional<call::Reply> delivered;
  call::Responder responder = audit->recording(request, std::chrono::steady_clock::now(),
                                               call::Responder::from_callback([&](call::Reply r) { delivered = r; }));
  EXPECT_TRUE(lines_of(file_).empty());  // recorded when answered
  responder.reply(call::Reply::success("SECRET-REPLY"));
  ASSERT_TRUE(delivered);
  EXPECT_EQ(delivered->payload, "SECRET-REPLY");  // handed on as it was
  audit->record_refusal(request, "space kr may not call jp/rt.Diagnostic0");
  request.oneway = true;
  call::Responder nowhere = audit->recording(request, std::chrono::steady_clock::now(), call::Responder());
  EXPECT_FALSE(nowhere.pending());  // a oneway's responder is returned as it is, recorded at once

  const auto lines = lines_of(file_);
  ASSERT_EQ(lines.size(), 3u);
  EXPECT_NE(lines[0].find("\"status\":\"OK\",\"trace_id\":\"4bf92f3577b34da6a3ce929d0e0e4736\""), std::string::npos)
      << lines[0];
  EXPECT_NE(lines[1].find("\"status\":\"PERMISSION_DENIED\",\"reason\":\"space kr may not call"), std::string::npos);
  EXPECT_NE(lines[2].find("\"oneway\":true"), std::string::npos) << lines[2];
  for (const auto& line : lines) EXPECT_EQ(line.find("SECRET"), std::string::npos) << line;
}

TEST_F(CallAuditTest, RotatesBySizeKeepingTheFilesConfigured) {
  auto audit = CallAudit::open({file_, 1024, 2});
  AuditEntry entry;
  entry.caller = {"kr", "dds:kr", federation::kVerifiedSpaceRole};
  entry.service = "rt.Diagnostic0";
  entry.operation = "ping";
  for (int i = 0; i < 40; ++i) audit->record(entry);  // ~200 bytes each: 8 KB through 1 KB files
  EXPECT_TRUE(std::filesystem::exists(folder_ + "/calls.1.jsonl"));
  EXPECT_TRUE(std::filesystem::exists(folder_ + "/calls.2.jsonl"));
  EXPECT_FALSE(std::filesystem::exists(folder_ + "/calls.3.jsonl"));
  for (const char* name : {"/calls.jsonl", "/calls.1.jsonl", "/calls.2.jsonl"}) {
    EXPECT_LE(std::filesystem::file_size(folder_ + name), 1024u) << name;
    EXPECT_FALSE(lines_of(folder_ + name).empty()) << name;
  }
}

TEST_F(CallAuditTest, AFileThatCannotBeOpenedIsNamed) {
  std::ofstream(folder_ + "/a-file") << "not a folder";
  try {
    CallAudit::open({folder_ + "/a-file/calls.jsonl", 4096, 1});
    FAIL() << "opened";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("dds.audit.file '" + folder_ + "/a-file/calls.jsonl' cannot be opened"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace urs::bridge
