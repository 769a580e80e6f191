// Compiled with the stubs' modules renamed: UrsTest::Scalars below is corba_UrsTest::Scalars.

#include "stub_side.hpp"

#include <functional>
#include <map>
#include <stdexcept>

#include "AllTypes.hh"
#include "Diagnostic.hh"
#include "ImageRecognition.hh"
#include "Localization.hh"
#include "Navigation.hh"

namespace urs::test {
namespace {

template <typename T>
std::string echo(const std::string& cdr) {
  cdrMemoryStream in;
  in.put_octet_array(reinterpret_cast<const CORBA::Octet*>(cdr.data()), static_cast<int>(cdr.size()));
  T value;
  value <<= in;
  if (in.checkInputOverrun(1, 1)) throw std::length_error("bytes remain after the value");
  cdrMemoryStream out;
  value >>= out;
  return std::string(static_cast<const char*>(out.bufPtr()), out.bufSize());
}

struct Stub {
  std::function<std::string(const std::string&)> echo;
  CORBA::TypeCode_ptr type_code;
};

const std::map<std::string, Stub>& stubs() {
  static const std::map<std::string, Stub> table{
      {"UrsTest::Scalars", {echo<UrsTest::Scalars>, UrsTest::_tc_Scalars}},
      {"UrsTest::Containers", {echo<UrsTest::Containers>, UrsTest::_tc_Containers}},
      {"UrsTest::Node", {echo<UrsTest::Node>, UrsTest::_tc_Node}},
      {"UrsTest::Outer", {echo<UrsTest::Outer>, UrsTest::_tc_Outer}},
      {"UrsTest::Value", {echo<UrsTest::Value>, UrsTest::_tc_Value}},
      {"UrsTest::Toggle", {echo<UrsTest::Toggle>, UrsTest::_tc_Toggle}},
      {"UrsTest::Letter", {echo<UrsTest::Letter>, UrsTest::_tc_Letter}},
      {"UrsTest::Pick", {echo<UrsTest::Pick>, UrsTest::_tc_Pick}},
      {"UrsTest::Oops", {echo<UrsTest::Oops>, UrsTest::_tc_Oops}},
      {"UrsTest::Derived::Step", {echo<UrsTest::Derived::Step>, UrsTest::Derived::_tc_Step}},
      {"URC::Pose2D", {echo<URC::Pose2D>, URC::_tc_Pose2D}},
      {"URC::PoseWithCovariance", {echo<URC::PoseWithCovariance>, URC::_tc_PoseWithCovariance}},
      {"URC::Marker", {echo<URC::Marker>, URC::_tc_Marker}},
      {"URC::Image", {echo<URC::Image>, URC::_tc_Image}},
      {"URC::InvalidTarget", {echo<URC::InvalidTarget>, URC::_tc_InvalidTarget}},
      {"URS::Failure", {echo<URS::Failure>, URS::_tc_Failure}},
  };
  return table;
}

}  // namespace

CORBA::ORB_ptr test_orb() {
  static CORBA::ORB_var orb = [] {
    int argc = 0;
    return CORBA::ORB_init(argc, nullptr);
  }();
  return orb.in();
}

std::string stub_echo(const std::string& type, const std::string& cdr) {
  const auto it = stubs().find(type);
  if (it == stubs().end()) throw std::invalid_argument("no stub for " + type);
  return it->second.echo(cdr);
}

CORBA::TypeCode_ptr stub_type_code(const std::string& type) {
  const auto it = stubs().find(type);
  return it == stubs().end() ? CORBA::TypeCode::_nil() : CORBA::TypeCode::_duplicate(it->second.type_code);
}

}  // namespace urs::test
