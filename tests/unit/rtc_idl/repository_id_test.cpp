// Repository IDs of urs::rtc_idl: the prefixes (omg.org, the reversed org.omg, openrtm.aist.go.jp,
// none) are what OpenRTM-aist peers compare on the wire (docs/rtc.md).
#include <gtest/gtest.h>

#include <string>

#include "BasicDataType.hh"
#include "DataPort.hh"
#include "ExtendedDataTypes.hh"
#include "OpenRTM.hh"
#include "RTC.hh"
#include "SDOPackage.hh"

namespace {

std::string Id(CORBA::TypeCode_ptr tc) { return tc->id(); }

TEST(RtcIdlRepositoryId, RtcModuleUsesOmgOrgPrefix) {
  EXPECT_EQ(std::string(RTC::RTObject::_PD_repoId), "IDL:omg.org/RTC/RTObject:1.0");
  EXPECT_EQ(std::string(RTC::LightweightRTObject::_PD_repoId), "IDL:omg.org/RTC/LightweightRTObject:1.0");
  EXPECT_EQ(std::string(RTC::ComponentAction::_PD_repoId), "IDL:omg.org/RTC/ComponentAction:1.0");
  EXPECT_EQ(std::string(RTC::ExecutionContext::_PD_repoId), "IDL:omg.org/RTC/ExecutionContext:1.0");
  EXPECT_EQ(std::string(RTC::ExecutionContextService::_PD_repoId), "IDL:omg.org/RTC/ExecutionContextService:1.0");
  EXPECT_EQ(std::string(RTC::PortService::_PD_repoId), "IDL:omg.org/RTC/PortService:1.0");
  EXPECT_EQ(std::string(RTC::DataFlowComponent::_PD_repoId), "IDL:omg.org/RTC/DataFlowComponent:1.0");
  EXPECT_EQ(std::string(RTC::DataFlowComponentAction::_PD_repoId), "IDL:omg.org/RTC/DataFlowComponentAction:1.0");

  EXPECT_EQ(Id(RTC::_tc_RTObject), "IDL:omg.org/RTC/RTObject:1.0");
  EXPECT_EQ(Id(RTC::_tc_ConnectorProfile), "IDL:omg.org/RTC/ConnectorProfile:1.0");
  EXPECT_EQ(Id(RTC::_tc_PortProfile), "IDL:omg.org/RTC/PortProfile:1.0");
  EXPECT_EQ(Id(RTC::_tc_PortInterfaceProfile), "IDL:omg.org/RTC/PortInterfaceProfile:1.0");
  EXPECT_EQ(Id(RTC::_tc_PortInterfacePolarity), "IDL:omg.org/RTC/PortInterfacePolarity:1.0");
  EXPECT_EQ(Id(RTC::_tc_ComponentProfile), "IDL:omg.org/RTC/ComponentProfile:1.0");
  EXPECT_EQ(Id(RTC::_tc_ExecutionContextProfile), "IDL:omg.org/RTC/ExecutionContextProfile:1.0");
  EXPECT_EQ(Id(RTC::_tc_ReturnCode_t), "IDL:omg.org/RTC/ReturnCode_t:1.0");
  EXPECT_EQ(Id(RTC::_tc_LifeCycleState), "IDL:omg.org/RTC/LifeCycleState:1.0");
  EXPECT_EQ(Id(RTC::_tc_ExecutionKind), "IDL:omg.org/RTC/ExecutionKind:1.0");
  EXPECT_EQ(Id(RTC::_tc_ExecutionContextHandle_t), "IDL:omg.org/RTC/ExecutionContextHandle_t:1.0");
  EXPECT_EQ(Id(RTC::_tc_NVList), "IDL:omg.org/RTC/NVList:1.0");
  EXPECT_EQ(Id(RTC::_tc_UniqueIdentifier), "IDL:omg.org/RTC/UniqueIdentifier:1.0");
}

TEST(RtcIdlRepositoryId, SdoPackageUsesReversedOrgOmgPrefix) {
  EXPECT_EQ(std::string(SDOPackage::SDO::_PD_repoId), "IDL:org.omg/SDOPackage/SDO:1.0");
  EXPECT_EQ(std::string(SDOPackage::SDOSystemElement::_PD_repoId), "IDL:org.omg/SDOPackage/SDOSystemElement:1.0");
  EXPECT_EQ(std::string(SDOPackage::SDOService::_PD_repoId), "IDL:org.omg/SDOPackage/SDOService:1.0");
  EXPECT_EQ(std::string(SDOPackage::Configuration::_PD_repoId), "IDL:org.omg/SDOPackage/Configuration:1.0");
  EXPECT_EQ(std::string(SDOPackage::Monitoring::_PD_repoId), "IDL:org.omg/SDOPackage/Monitoring:1.0");
  EXPECT_EQ(std::string(SDOPackage::Organization::_PD_repoId), "IDL:org.omg/SDOPackage/Organization:1.0");

  EXPECT_EQ(Id(SDOPackage::_tc_NameValue), "IDL:org.omg/SDOPackage/NameValue:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_NVList), "IDL:org.omg/SDOPackage/NVList:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_UniqueIdentifier), "IDL:org.omg/SDOPackage/UniqueIdentifier:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_DeviceProfile), "IDL:org.omg/SDOPackage/DeviceProfile:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_ServiceProfile), "IDL:org.omg/SDOPackage/ServiceProfile:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_NotAvailable), "IDL:org.omg/SDOPackage/NotAvailable:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_InterfaceNotImplemented), "IDL:org.omg/SDOPackage/InterfaceNotImplemented:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_InvalidParameter), "IDL:org.omg/SDOPackage/InvalidParameter:1.0");
  EXPECT_EQ(Id(SDOPackage::_tc_InternalError), "IDL:org.omg/SDOPackage/InternalError:1.0");
  EXPECT_EQ(std::string(SDOPackage::NotAvailable::_PD_repoId), "IDL:org.omg/SDOPackage/NotAvailable:1.0");
}

TEST(RtcIdlRepositoryId, OpenRtmComponentUsesOpenRtmPrefix) {
  EXPECT_EQ(std::string(OpenRTM::DataFlowComponent::_PD_repoId),
            "IDL:openrtm.aist.go.jp/OpenRTM/DataFlowComponent:1.0");
  EXPECT_EQ(Id(OpenRTM::_tc_DataFlowComponent), "IDL:openrtm.aist.go.jp/OpenRTM/DataFlowComponent:1.0");
}

TEST(RtcIdlRepositoryId, DataPortTransferHasNoPrefix) {
  EXPECT_EQ(std::string(OpenRTM::InPortCdr::_PD_repoId), "IDL:OpenRTM/InPortCdr:1.0");
  EXPECT_EQ(std::string(OpenRTM::OutPortCdr::_PD_repoId), "IDL:OpenRTM/OutPortCdr:1.0");
  EXPECT_EQ(Id(OpenRTM::_tc_PortStatus), "IDL:OpenRTM/PortStatus:1.0");
  EXPECT_EQ(Id(OpenRTM::_tc_CdrData), "IDL:OpenRTM/CdrData:1.0");
}

TEST(RtcIdlRepositoryId, DataTypesHaveNoPrefix) {
  EXPECT_EQ(Id(RTC::_tc_Time), "IDL:RTC/Time:1.0");
  EXPECT_EQ(Id(RTC::_tc_TimedLong), "IDL:RTC/TimedLong:1.0");
  EXPECT_EQ(Id(RTC::_tc_TimedDouble), "IDL:RTC/TimedDouble:1.0");
  EXPECT_EQ(Id(RTC::_tc_TimedString), "IDL:RTC/TimedString:1.0");
  EXPECT_EQ(Id(RTC::_tc_TimedOctetSeq), "IDL:RTC/TimedOctetSeq:1.0");
  EXPECT_EQ(Id(RTC::_tc_Point2D), "IDL:RTC/Point2D:1.0");
  EXPECT_EQ(Id(RTC::_tc_Pose2D), "IDL:RTC/Pose2D:1.0");
  EXPECT_EQ(Id(RTC::_tc_TimedPose2D), "IDL:RTC/TimedPose2D:1.0");
  EXPECT_EQ(Id(RTC::_tc_CameraImage), "IDL:RTC/CameraImage:1.0");
}

}  // namespace
