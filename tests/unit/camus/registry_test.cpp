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
  ASSERT_EQ(route->providers.size(), 1u);
  EXPECT_EQ(route->providers[0].session.get(), sam1.get());
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
  EXPECT_EQ(refused.message(),
            "service robot1.navigation is provided by sam@robot1; only sessions of that credential may provide it "
            "too");
  EXPECT_EQ(registry.list("")[0].owner(), "sam@robot1");
  EXPECT_EQ(registry.list("")[0].providers_size(), 1);
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
  ASSERT_EQ(route->providers.size(), 1u);
  EXPECT_EQ(route->providers[0].session.get(), again.get());
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

TEST_F(RegistryTest, ASecondSessionOfTheSameCredentialBecomesASecondProvider) {
  // A replica of the SAM that holds the service: the same credential, its own session. It takes
  // nothing over: the first provider stays first and keeps its share of the calls.
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation", 2500)).ok());
  auto replica = std::make_shared<FakeSession>(9, "sam@robot1", planet::SAM);
  ASSERT_TRUE(registry.register_service(replica, navigation_registration("robot1.navigation", 900)).ok());

  auto listed = registry.list("");
  ASSERT_EQ(listed.size(), 1u) << "one service, not one per provider";
  EXPECT_EQ(listed[0].owner(), "sam@robot1");
  EXPECT_EQ(listed[0].deadline_ms(), 2500u) << "the service's fields are its first provider's";
  ASSERT_EQ(listed[0].providers_size(), 2);
  EXPECT_EQ(listed[0].providers(0).connection(), 1u);
  EXPECT_EQ(listed[0].providers(1).connection(), 9u);
  EXPECT_EQ(listed[0].providers(1).owner(), "sam@robot1");
  EXPECT_EQ(listed[0].providers(1).deadline_ms(), 900u);
  auto route = registry.route("robot1.navigation");
  ASSERT_TRUE(route.has_value());
  ASSERT_EQ(route->providers.size(), 2u);
  EXPECT_EQ(route->providers[0].session.get(), sam1.get());
  EXPECT_EQ(route->providers[1].session.get(), replica.get());

  auto events = sink.events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].as<camus::ServiceInfo>().change(), "registered");
  const auto added = events[1].as<camus::ServiceInfo>();
  EXPECT_EQ(events[1].topic, "registry/robot1.navigation");
  EXPECT_EQ(added.state(), "available");
  EXPECT_EQ(added.change(), "provider-added");
  EXPECT_EQ(added.changed_provider().connection(), 9u);
  EXPECT_EQ(added.providers_size(), 2);

  // Each provider unregisters only itself.
  EXPECT_TRUE(registry.unregister_service(*replica, "robot1.navigation").ok());
  ASSERT_EQ(registry.list("").size(), 1u);
  EXPECT_EQ(registry.list("")[0].providers_size(), 1);
  EXPECT_EQ(registry.route("robot1.navigation")->providers.at(0).session.get(), sam1.get());
}

TEST_F(RegistryTest, AServiceStaysWhileOneOfItsProvidersRemains) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation", 2500)).ok());
  auto replica = std::make_shared<FakeSession>(9, "sam@robot1", planet::SAM);
  ASSERT_TRUE(registry.register_service(replica, navigation_registration("robot1.navigation", 900)).ok());

  // The first provider's connection closes: the service stays, now the replica's.
  EXPECT_TRUE(registry.remove_session(1).empty()) << "nothing is gone while a provider remains";
  auto listed = registry.list("");
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].state(), "available");
  EXPECT_EQ(listed[0].deadline_ms(), 900u);
  ASSERT_EQ(listed[0].providers_size(), 1);
  EXPECT_EQ(listed[0].providers(0).connection(), 9u);
  auto events = sink.events();
  ASSERT_EQ(events.size(), 3u);
  const auto removed = events[2].as<camus::ServiceInfo>();
  EXPECT_EQ(removed.state(), "available") << "the service is not announced gone while a provider remains";
  EXPECT_EQ(removed.change(), "provider-removed");
  EXPECT_EQ(removed.changed_provider().connection(), 1u);
  EXPECT_EQ(removed.providers_size(), 1);

  // The last provider's connection closes: now it is gone.
  EXPECT_EQ(registry.remove_session(9), (std::vector<std::string>{"robot1.navigation"}));
  EXPECT_TRUE(registry.list("").empty());
  events = sink.events();
  ASSERT_EQ(events.size(), 4u);
  EXPECT_EQ(events[3].as<camus::ServiceInfo>().state(), "gone");
  EXPECT_EQ(events[3].as<camus::ServiceInfo>().change(), "disconnected");
  EXPECT_EQ(events[3].as<camus::ServiceInfo>().changed_provider().connection(), 9u);
  EXPECT_FALSE(registry.route("robot1.navigation").has_value());
}

TEST_F(RegistryTest, NoOtherCredentialMayCoProvideWhateverItsRole) {
  // Providing a service is being handed its callers' requests: a credential that does not hold
  // the service cannot add itself, not even an operator's, nor one declaring the provider's name.
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto operator_session = std::make_shared<FakeSession>(4, "ops", planet::OPERATOR);
  auto impostor = std::make_shared<FakeSession>(5, "sam@robot2", planet::SAM);
  impostor->declare_peer_name("sam@robot1");
  for (const auto& stranger : {operator_session, impostor}) {
    auto refused = registry.register_service(stranger, navigation_registration("robot1.navigation"));
    EXPECT_EQ(refused.status(), planet::ALREADY_EXISTS);
    EXPECT_EQ(refused.message(),
              "service robot1.navigation is provided by sam@robot1; only sessions of that credential may provide it "
              "too");
    EXPECT_EQ(registry.unregister_service(*stranger, "robot1.navigation").status(), planet::PERMISSION_DENIED);
  }
  ASSERT_EQ(registry.list("")[0].providers_size(), 1);
  EXPECT_EQ(registry.route("robot1.navigation")->providers.size(), 1u);
  EXPECT_EQ(sink.events().size(), 1u) << "a refusal changes nothing";
}

TEST_F(RegistryTest, ASecondProviderRegistersTheSameInterfaceAndDescription) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto replica = std::make_shared<FakeSession>(9, "sam@robot1", planet::SAM);

  auto other_interface = navigation_registration("robot1.navigation");
  other_interface.mutable_service()->set_interface("test.Base");
  other_interface.clear_descriptor_set();
  auto refused = registry.register_service(replica, other_interface);
  EXPECT_EQ(refused.status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(refused.message(),
            "service robot1.navigation is provided by sam@robot1 with interface test.Navigation; another provider "
            "must register the same interface, not 'test.Base'");

  // test.Navigation described otherwise (one operation more).
  google::protobuf::FileDescriptorSet set;
  ASSERT_TRUE(set.ParseFromString(navigation_descriptor_set()));
  auto* method = set.mutable_file(0)->mutable_service(0)->add_method();
  *method = set.file(0).service(0).method(0);
  method->set_name("fly");
  auto other_description = navigation_registration("robot1.navigation");
  other_description.set_descriptor_set(set.SerializeAsString());
  refused = registry.register_service(replica, other_description);
  EXPECT_EQ(refused.status(), planet::ALREADY_EXISTS);
  EXPECT_EQ(refused.message(),
            "service robot1.navigation is provided by sam@robot1 with another description of interface "
            "test.Navigation (its descriptor_set differs); another provider must register the same one");
  EXPECT_EQ(registry.list("")[0].providers_size(), 1);

  // Without a description it joins, and the service keeps the one it had.
  auto undescribed = navigation_registration("robot1.navigation");
  undescribed.clear_descriptor_set();
  ASSERT_TRUE(registry.register_service(replica, undescribed).ok());
  EXPECT_EQ(registry.list("")[0].providers_size(), 2);
  ASSERT_NE(registry.route("robot1.navigation")->schema, nullptr);
  EXPECT_EQ(registry.route("robot1.navigation")->schema->service().FindMethodByName("fly"), nullptr);

  // While it has company a provider cannot change the interface; alone it may.
  refused = registry.register_service(sam1, other_interface);
  EXPECT_EQ(refused.status(), planet::ALREADY_EXISTS);
  registry.remove_session(9);
  EXPECT_TRUE(registry.register_service(sam1, other_interface).ok());
  EXPECT_EQ(registry.list("")[0].interface(), "test.Base");
}

TEST_F(RegistryTest, AResumedProviderReplacesOnlyItself) {
  ASSERT_TRUE(registry.register_service(sam1, navigation_registration("robot1.navigation")).ok());
  auto replica = std::make_shared<FakeSession>(9, "sam@robot1", planet::SAM, 109);
  ASSERT_TRUE(registry.register_service(replica, navigation_registration("robot1.navigation")).ok());
  // The replica reconnects and resumes its session before its old connection timed out.
  auto resumed = std::make_shared<FakeSession>(10, "sam@robot1", planet::SAM, 109);
  ASSERT_TRUE(registry.register_service(resumed, navigation_registration("robot1.navigation")).ok());
  auto listed = registry.list("");
  ASSERT_EQ(listed[0].providers_size(), 2);
  EXPECT_EQ(listed[0].providers(0).connection(), 1u);
  EXPECT_EQ(listed[0].providers(1).connection(), 10u);
  EXPECT_EQ(sink.events().back().as<camus::ServiceInfo>().change(), "updated");
  EXPECT_TRUE(registry.remove_session(9).empty());
  EXPECT_EQ(registry.list("")[0].providers_size(), 2) << "the old connection closing removes nothing";
}

TEST_F(RegistryTest, BadRegistrationsAreRefusedPrecisely) {
  auto bad_name = navigation_registration("robot 1");
  EXPECT_EQ(registry.register_service(sam1, bad_name).message(),
            "service name 'robot 1' is not valid: character ' ' is not allowed (use letters, digits and . _ - @ : /)");
  EXPECT_EQ(registry.register_service(sam1, navigation_registration("camus.mine")).message(),
            "service name 'camus.mine' is not valid: names starting with 'camus.' are reserved for the server");
  // A name is announced on registry/<name>: no empty level.
  for (const char* name : {"/x", "a//b", "x/"}) {
    EXPECT_EQ(registry.register_service(sam1, navigation_registration(name)).message(),
              std::string("service name '") + name +
                  "' is not valid: it has an empty level (a '/' at its start or end, or '//'): each part between "
                  "slashes needs a character");
  }
  // What a peer sent is quoted, not echoed whole.
  const std::string huge(100000, 'h');
  const std::string refused_huge = registry.register_service(sam1, navigation_registration(huge)).message();
  EXPECT_LT(refused_huge.size(), 300u);
  EXPECT_NE(refused_huge.find("(100000 bytes)"), std::string::npos) << refused_huge;
  auto garbage = navigation_registration("robot1.nav");
  garbage.set_descriptor_set("not a descriptor set");
  auto refused = registry.register_service(sam1, garbage);
  EXPECT_EQ(refused.status(), planet::BAD_ARGUMENTS);
  EXPECT_EQ(refused.message(),
            "service robot1.nav: descriptor_set for test.Navigation does not load: the 20 bytes received are not a "
            "serialized google.protobuf.FileDescriptorSet");
  auto wrong_interface = navigation_registration("robot1.nav");
  wrong_interface.mutable_service()->set_interface("test.Missing");
  EXPECT_EQ(
      registry.register_service(sam1, wrong_interface).message(),
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
