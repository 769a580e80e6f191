#include "navigation_stub.hpp"

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <omniORB4/CORBA.h>
#include <omniORB4/minorCode.h>

#include <algorithm>
#include <cstdint>
#include <stdexcept>

#include "Navigation.hh"
#include "urs/rt_call/provider_port.hpp"
#include "urs/rtc/naming.hpp"
#include "urs/rtc/orb.hpp"
#include "urs/rtc/tools.hpp"

namespace urs::lab {

namespace gp = google::protobuf;

namespace {

const gp::FieldDescriptor& field_of(const gp::Message& message, const char* name) {
  const gp::FieldDescriptor* field = message.GetDescriptor()->FindFieldByName(name);
  if (field == nullptr) throw std::logic_error(message.GetTypeName() + " has no field " + name);
  return *field;
}

double double_of(const gp::Message& message, const char* name) {
  return message.GetReflection()->GetDouble(message, &field_of(message, name));
}

class NavigationStub : public RemoteService {
 public:
  NavigationStub(URC::Navigation_ptr navigation, std::string where)
      : navigation_(URC::Navigation::_duplicate(navigation)), where_(std::move(where)) {}

  planet::CallResult call(const std::string& operation, const gp::Message& request, gp::Message& reply,
                          std::chrono::milliseconds deadline) override {
    omniORB::setClientCallTimeout(navigation_, static_cast<CORBA::ULong>(std::max<std::int64_t>(1, deadline.count())));
    try {
      if (operation == "moveTo") {
        navigation_->moveTo(double_of(request, "x"), double_of(request, "y"));
      } else if (operation == "setSpeed") {
        const auto speed = request.GetReflection()->GetUInt32(request, &field_of(request, "speed"));
        navigation_->setSpeed(static_cast<URC::MillimetresPerSecond>(speed));
      } else if (operation == "stop") {
        navigation_->stop();
      } else if (operation == "_get_state") {
        // The IDL enumerators keep their order as Protobuf numbers (docs/idl-mapping.md).
        reply.GetReflection()->SetEnumValue(&reply, &field_of(reply, "result"), static_cast<int>(navigation_->state()));
      } else if (operation == "getPosition") {
        const URC::Pose2D pose = navigation_->getPosition();
        gp::Message* result = reply.GetReflection()->MutableMessage(&reply, &field_of(reply, "result"));
        result->GetReflection()->SetDouble(result, &field_of(*result, "x"), pose.x);
        result->GetReflection()->SetDouble(result, &field_of(*result, "y"), pose.y);
        result->GetReflection()->SetDouble(result, &field_of(*result, "theta"), pose.theta);
      } else {
        return planet::CallResult::error(planet::UNKNOWN_OPERATION, operation + " is not called through the stubs");
      }
      return planet::CallResult::success(reply.SerializeAsString());
    } catch (const CORBA::UserException& e) {
      return planet::CallResult::error(planet::USER_EXCEPTION, operation + " raised " + e._rep_id());
    } catch (const CORBA::TIMEOUT& e) {
      return planet::CallResult::error(planet::DEADLINE_EXCEEDED, operation + ": " + rtc::describe(e));
    } catch (const CORBA::TRANSIENT& e) {
      const auto status = e.minor() == omni::TRANSIENT_CallTimedout ? planet::DEADLINE_EXCEEDED : planet::UNAVAILABLE;
      return planet::CallResult::error(status, operation + ": " + rtc::describe(e));
    } catch (const CORBA::SystemException& e) {
      return planet::CallResult::error(planet::UNAVAILABLE, operation + ": " + rtc::describe(e));
    }
  }

  std::string where() const override { return "RT provider " + where_ + " (omniORB stubs)"; }

 private:
  URC::Navigation_var navigation_;
  std::string where_;
};

}  // namespace

std::unique_ptr<RemoteService> rt_navigation_stub(rtc::Orb& orb, rtc::NamingClient& naming,
                                                  const std::string& port_address) {
  const auto colon = port_address.rfind(':');
  if (colon == std::string::npos) throw std::runtime_error("'" + port_address + "' is not PATH:PORT");
  CORBA::Object_var object = naming.resolve(port_address.substr(0, colon));
  RTC::RTObject_var component = RTC::RTObject::_narrow(object);
  if (CORBA::is_nil(component)) throw std::runtime_error(port_address.substr(0, colon) + " is not an RT-Component");
  RTC::PortService_var port = rtc::find_port(component, port_address.substr(colon + 1));
  if (CORBA::is_nil(port)) throw std::runtime_error(port_address + ": no such port");
  for (const auto& provided : rt_call::offered_by(port)) {
    CORBA::Object_var target = orb.string_to_object(provided.ior);
    if (!target->_is_a("IDL:URC/Navigation:1.0")) continue;
    URC::Navigation_var navigation = URC::Navigation::_narrow(target);
    if (!CORBA::is_nil(navigation)) return std::make_unique<NavigationStub>(navigation, port_address);
  }
  throw std::runtime_error(port_address + " provides no IDL:URC/Navigation:1.0");
}

}  // namespace urs::lab
