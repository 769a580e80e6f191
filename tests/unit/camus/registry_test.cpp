#include "urs/camus_server/registry.hpp"

#include <gtest/gtest.h>

#include "fakes.hpp"

namespace urs::camus_server::test {
namespace {

class RegistryTest : public ::testing::Test {
 protected:
  RecordingSink sink;
  Registry registry{"kr", sink};
  std::shared_ptr<FakeSession> sam1 = std::make_shared<FakeSession>(1, "sam@robot1", planet::SAM, 101);
  std::shared_ptr<FakeSession> sam2 = std::make_shared<FakeSession>(2, "sam@robot2", planet::SAM, 102);
};

TEST_F(RegistryTest, RegistrationFillsOwnerAndStateAndPublishes) {
  auto done = registry.register_service(sam1, navigation_registration("robot1.navigation", 2500));
  ASSERT_TRUE(done.ok()) << done.message();
  auto listed = registry.list("");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].name(), "robot1.navigation");
  EXPECT_EQ(listed[0].owner(), "sam@robot1");
  EXPECT_EQ(listed[0].state(), "available");
  EXPECT_EQ(listed[0].deadline_ms(), 2500u);
  auto events = sink.events();
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].topic, "registry/robot1.navigation");
  EXPECT_EQ(events[0].type, "urs.camus.ServiceInfo");
  EXPECT_EQ(events[0].as<camus::ServiceInfo>().state(), "available");

  auto route = registry.route("robot1.navigation");
  ASSERT_TRUE(route.has_value());
  EXPECT_FALSE(route->builtin);
  EXPECT_EQ(route->owner.get(), sam1.get());
  ASSERT_NE(route->schema, nullptr);
  EXPECT_NE(route->schema->service().FindMethodByName("moveTo"), nullptr);
}

TEST_F(RegistryTest, ProvidersOfOneInterfaceShareItsDescription) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  ASSERT_TRUE(registry.register_service(sam2, navigation_registration("robot2.navigation")).ok());
  auto first = registry.route("robot1.navigation");
  auto second = registry.route("robot2.navigation");
  ASSERT_TRUE(first.has_value() && second.has_value());
  ASSERT_NE(first->schema, nullptr);
  EXPECT_EQ(first->schema.get(), second->schema.get()) << "one descriptor pool per registration";
}

TEST_F(RegistryTest, NameOwnedByAnotherLiveSessionIsRefused) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto refused = registry.register_service(sam2, navigation_registration("robot1.navigation"));
  ASSERT_FALSE(refused.ok());
  EXPECT_EQ(refused.status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(refused.message(), "service robot1.navigation is provided by sam@robot1");
  EXPECT_EQ(registry.list("")[0].owner(), "sam@robot1");
}

TEST_F(RegistryTest, SameSessionReRegisteringReplaces) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation", 100)).ok());
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation", 200)).ok());
  auto listed = registry.list("");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].deadline_ms(), 200u);
}

TEST_F(RegistryTest, ResumedSessionReplacesAndOldCloseKeepsIt) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto again = std::make_shared<FakeSession>(7, "sam@robot1", planet::SAM, 101);  // resumed: same Identity::session
  ASSERT_TRUE(registry.register_service(again, navigation_registration("robot1.navigation")).ok());
  // The old connection is declared dead later: the service now belongs to the new one.
  EXPECT_TRUE(registry.remove_session(1).empty());
  auto route = registry.route("robot1.navigation");
  ASSERT_TRUE(route.has_value());
  EXPECT_EQ(route->owner.get(), again.get());
}

TEST_F(RegistryTest, OwnerCloseRemovesItsServicesAndPublishesGone) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.base")).ok());
  ASSERT_TRUE(registry.register_service(sam2, navigation_registration("robot2.navigation")).ok());
  auto removed = registry.remove_session(1);
  EXPECT_EQ(removed, (std::vector<std::string>{"robot1.base", "robot1.navigation"}));
  auto listed = registry.list("");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].name(), "robot2.navigation");
  auto events = sink.events();
  ASSERT_EQ(events.size(), 5u);
  EXPECT_EQ(events[3].topic, "registry/robot1.base");
  EXPECT_EQ(events[3].as<camus::ServiceInfo>().state(), "gone");
  EXPECT_EQ(events[4].topic, "registry/robot1.navigation");
  EXPECT_EQ(events[4].as<camus::ServiceInfo>().state(), "gone");
  EXPECT_FALSE(registry.route("robot1.navigation").has_value());
}

TEST_F(RegistryTest, OnlySamAndOperatorRolesRegister) {
  auto client = std::make_shared<FakeSession>(3, "cli", planet::CLIENT);
  auto refused = registry.register_service(client, navigation_registration("x.nav"));
  EXPECT_EQ(refused.status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(refused.message(), "registering services needs role sam; credential 'cli' has role client");
  auto operator_session = std::make_shared<FakeSession>(4, "ops", planet::OPERATOR);
  EXPECT_TRUE(registry.register_service(operator_session, navigation_registration("x.nav")).ok());
}

TEST_F(RegistryTest, SameNameOnAnotherSessionIsNotTheSameOwner) {
  // The owner is the authenticated session, not a name: a second session of the same credential
  // (or a stranger declaring the same peer name) cannot take the service over.
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto same_name = std::make_shared<FakeSession>(9, "sam@robot1", planet::SAM);
  auto refused = registry.register_service(same_name, navigation_registration("robot1.navigation"));
  EXPECT_EQ(refused.status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(registry.unregister_service(*same_name, "robot1.navigation").status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(registry.route("robot1.navigation")->owner.get(), sam1.get());
}

TEST_F(RegistryTest, BadRegistrationsAreRefusedPrecisely) {
  auto bad_name = navigation_registration("robot 1");
  EXPECT_EQ(registry.register_service(sam1, bad_name).message(),
            "service name 'robot 1' is not valid: character ' ' is not allowed (use letters, digits and . _ - @ : /)");
  EXPECT_EQ(registry.register_service(sam1, navigation_registration("camus.mine")).message(),
            "service name 'camus.mine' is not valid: names starting with 'camus.' are reserved for the server");
  auto garbage = navigation_registration("robot1.nav");
  garbage.set_descriptor_set("not a descriptor set");
  auto refused = registry.register_service(sam1, garbage);
  EXPECT_EQ(refused.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(refused.message(),
            "service robot1.nav: descriptor_set for test.Navigation does not load: the 20 bytes received are not a "
            "serialized google.protobuf.FileDescriptorSet");
  auto wrong_interface = navigation_registration("robot1.nav");
  wrong_interface.mutable_service()->set_interface("test.Missing");
  EXPECT_EQ(registry.register_service(sam1, wrong_interface).message(),
            "service robot1.nav: descriptor_set does not describe interface test.Missing: it does not define that service");
  auto no_interface = navigation_registration("robot1.nav");
  no_interface.mutable_service()->clear_interface();
  EXPECT_EQ(registry.register_service(sam1, no_interface).message(),
            "service robot1.nav: interface is empty (give the full Protobuf service name)");
  EXPECT_TRUE(registry.list("").empty());
}

TEST_F(RegistryTest, BuiltinsAreListedAndCannotBeTaken) {
  const auto* file = camus::ServiceInfo::descriptor()->file();
  registry.add_builtin("camus.context", *file->FindServiceByName("Context"));
  auto listed = registry.list("camus.*");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].owner(), "camus-server");
  EXPECT_EQ(listed[0].interface(), "urs.camus.Context");
  camus::DescribeRequest describe;
  describe.set_service("camus.context");
  auto described = registry.describe(describe);
  ASSERT_TRUE(described.ok());
  google::protobuf::FileDescriptorSet set;
  ASSERT_TRUE(set.ParseFromString(described->descriptor_set()));
  ASSERT_EQ(set.file_size(), 2);  // struct.proto first, then camus.proto
  EXPECT_EQ(set.file(0).name(), "google/protobuf/struct.proto");
  EXPECT_EQ(set.file(1).name(), file->name());

  auto route = registry.route("camus.context");
  ASSERT_TRUE(route.has_value());
  EXPECT_TRUE(route->builtin);
  EXPECT_THROW(registry.add_builtin("camus.context", *file->FindServiceByName("Context")), std::invalid_argument);
}

TEST_F(RegistryTest, ListFiltersWithGlobAndDescribeFindsInterfaces) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  ASSERT_TRUE(registry.register_service(sam2, navigation_registration("robot2.navigation")).ok());
  EXPECT_EQ(registry.list("robot2.*").size(), 1u);
  EXPECT_EQ(registry.list("*.navigation").size(), 2u);
  EXPECT_EQ(registry.list("nothing*").size(), 0u);

  camus::DescribeRequest by_interface;
  by_interface.set_interface("test.Navigation");
  auto described = registry.describe(by_interface);
  ASSERT_TRUE(described.ok());
  EXPECT_EQ(described->descriptor_set(), navigation_descriptor_set());

  camus::DescribeRequest unknown;
  unknown.set_service("robot9.navigation");
  EXPECT_EQ(registry.describe(unknown).message(), "no service named 'robot9.navigation' in space kr");
  EXPECT_EQ(registry.describe(unknown).status(), planet::UNKNOWN_SERVICE);
  camus::DescribeRequest unknown_interface;
  unknown_interface.set_interface("test.Nothing");
  EXPECT_EQ(registry.describe(unknown_interface).message(), "no registered service implements interface test.Nothing");
  EXPECT_EQ(registry.describe(camus::DescribeRequest()).status(), planet::BAD_ARGUMENTS);

  EXPECT_NE(registry.schema_with_message("test.Arrived"), nullptr);
  EXPECT_EQ(registry.schema_with_message("test.Nope"), nullptr);
}

TEST_F(RegistryTest, UnregisterOnlyByItsProvider) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto refused = registry.unregister_service(*sam2, "robot1.navigation");
  EXPECT_EQ(refused.status(), planet::PERMISSION_DENIED);
  EXPECT_EQ(refused.message(),
            "service robot1.navigation is provided by sam@robot1; only its provider may unregister it");
  EXPECT_EQ(registry.unregister_service(*sam1, "nope").message(), "no service named 'nope' in space kr");
  ASSERT_TRUE(registry.unregister_service(*sam1, "robot1.navigation").ok());
  EXPECT_TRUE(registry.list("").empty());
  EXPECT_EQ(sink.events().back().as<camus::ServiceInfo>().state(), "gone");
}

TEST_F(RegistryTest, ServiceAnswersOverPlanetRequests) {
  RegistryService service(registry);
  planet::Request request;
  request.set_service("camus.registry");
  request.set_operation("Register");
  request.set_payload(navigation_registration("robot1.navigation").SerializeAsString());
  auto result = service.handle(sam1, request);
  ASSERT_TRUE(result.ok()) << result.message;

  request.set_operation("List");
  request.set_payload(camus::ListRequest().SerializeAsString());
  result = service.handle(nullptr, request);
  ASSERT_TRUE(result.ok());
  camus::ListReply list;
  ASSERT_TRUE(list.ParseFromString(result.payload));
  ASSERT_EQ(list.services_size(), 1);

  request.set_operation("Register");
  request.set_payload("\xff\xff");
  result = service.handle(sam1, request);
  EXPECT_EQ(result.status, planet::BAD_ARGUMENTS);
  EXPECT_EQ(result.message, "payload of camus.registry.Register is not a valid urs.camus.RegisterRequest");

  request.set_operation("Explode");
  result = service.handle(sam1, request);
  EXPECT_EQ(result.status, planet::UNKNOWN_OPERATION);
  EXPECT_EQ(result.message, "interface urs.camus.Registry has no operation 'Explode'");
}

}  // namespace
}  // namespace urs::camus_server::test
