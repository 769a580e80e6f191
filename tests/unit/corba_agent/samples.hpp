#pragma once
// One value of each IDL type the tests convert, as Protobuf text, with its IDL name.

#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>
#include <google/protobuf/text_format.h>

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "AllTypes.pb.h"
#include "Diagnostic.pb.h"
#include "ImageRecognition.pb.h"
#include "Localization.pb.h"
#include "Navigation.pb.h"

namespace urs::test {

struct Sample {
  std::string idl_name;  // "UrsTest::Scalars"
  const google::protobuf::Descriptor* type;
  std::string text;  // Protobuf text format
};

inline const std::vector<Sample>& samples() {
  static const std::vector<Sample> all{
      {"UrsTest::Scalars", UrsTest::Scalars::descriptor(),
       R"(s: -12345 l: -7 us: 65535 ul: 4000000000 ll: -1099511627776 ull: 9223372036854775813
          f: 1.5 d: -2.25 b: true c: "é" wc: "€" o: 255 str: "hello" wstr: "καλη" bounded: "12345678"
          ticks: 42)"},
      {"UrsTest::Containers", UrsTest::Containers::descriptor(),
       R"(blob: "\000\001\377" digest: "0123456789abcdef" longs: [1, 2, 3]
          nested { items: [1] } nested { items: [2, 3] } nested { }
          bounded_longs: [1, 2, 3, 4, 5] table: [1, 2, 3, 4, 5, 6]
          rows { items: [1, 2, 3, 4] } rows { items: [5, 6, 7, 8] } grid { items: [7] } grid { }
          colors: [COLOR_RED, COLOR_LIGHT_BLUE] points { x: 1 y: 2 } short_strings: ["ab", "abcd"]
          chunks: ["x", ""])"},
      {"UrsTest::Node", UrsTest::Node::descriptor(),
       R"(name: "root" children { name: "a" } children { name: "b" children { name: "c" } })"},
      {"UrsTest::Outer", UrsTest::Outer::descriptor(), R"(inside { v: 3 } state: OUTER_MODE_OFF)"},
      {"UrsTest::Value", UrsTest::Value::descriptor(), R"(discriminator: 1 i: -5)"},
      {"UrsTest::Value", UrsTest::Value::descriptor(), R"(discriminator: 3 s: "three")"},
      {"UrsTest::Value", UrsTest::Value::descriptor(), R"(discriminator: 4 many { items: [1, 2] })"},
      {"UrsTest::Value", UrsTest::Value::descriptor(), R"(discriminator: 5 quad { items: [1, 2, 3, 4] })"},
      {"UrsTest::Value", UrsTest::Value::descriptor(), R"(discriminator: 9 flag: true)"},
      {"UrsTest::Toggle", UrsTest::Toggle::descriptor(), R"(discriminator: true on_text: "on")"},
      {"UrsTest::Toggle", UrsTest::Toggle::descriptor(), R"(discriminator: false off_code: 7)"},
      {"UrsTest::Letter", UrsTest::Letter::descriptor(), R"(discriminator: "a" a: 5)"},
      {"UrsTest::Letter", UrsTest::Letter::descriptor(), R"(discriminator: "z" other: "zed")"},
      {"UrsTest::Pick", UrsTest::Pick::descriptor(), R"(discriminator: COLOR_GREEN p { x: 1 y: -1 })"},
      {"UrsTest::Pick", UrsTest::Pick::descriptor(), R"(discriminator: COLOR_LIGHT_BLUE)"},
      {"UrsTest::Oops", UrsTest::Oops::descriptor(), R"(what: "bad" tint: COLOR_GREEN)"},
      {"UrsTest::Derived::Step", UrsTest::Derived_Step::descriptor(), R"(at { x: 1 y: 2 } index: 7)"},
      {"URC::Pose2D", URC::Pose2D::descriptor(), R"(x: 1 y: 2 theta: 0.5)"},
      {"URC::PoseWithCovariance", URC::PoseWithCovariance::descriptor(),
       R"(x: 1 y: 2 theta: 3 covariance: [1, 0, 0, 0, 1, 0, 0, 0, 1] stamp { sec: 1700000000 nsec: 5 }
          frame: "map")"},
      {"URC::Marker", URC::Marker::descriptor(),
       R"(content: "qr" corners { x: 0 y: 0 } corners { x: 1 y: 0 } corners { x: 1 y: 1 } corners { x: 0 y: 1 }
          bbox { x: 0 y: 0 width: 1 height: 1 } confidence: 0.9)"},
      {"URC::Image", URC::Image::descriptor(),
       R"(format { width: 2 height: 1 encoding: IMAGE_ENCODING_PNG } stamp { sec: 1 } data: "abcdef")"},
      {"URC::InvalidTarget", URC::InvalidTarget::descriptor(), R"(x: 1 y: 2 reason: "wall")"},
      {"URS::Failure", URS::Failure::descriptor(), R"(reason: "on purpose" code: -3)"},
  };
  return all;
}

inline std::vector<const google::protobuf::Descriptor*> sample_types() {
  std::vector<const google::protobuf::Descriptor*> types;
  for (const auto& sample : samples()) types.push_back(sample.type);
  return types;
}

// A message of `type` parsed from `text`; throws std::invalid_argument if the text does not parse.
inline std::unique_ptr<google::protobuf::Message> parse(const google::protobuf::Descriptor& type,
                                                        const std::string& text) {
  std::unique_ptr<google::protobuf::Message> message(
      google::protobuf::MessageFactory::generated_factory()->GetPrototype(&type)->New());
  if (!google::protobuf::TextFormat::ParseFromString(text, message.get())) {
    throw std::invalid_argument("sample of " + type.full_name() + " does not parse");
  }
  return message;
}

}  // namespace urs::test
