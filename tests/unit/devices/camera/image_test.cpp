// Image encodings: PNG round trips, and URC images that cannot be read are refused by name.

#include <gtest/gtest.h>

#include "urs/camera/image_codec.hpp"
#include "urs/camera/recognizer.hpp"

namespace urs::camera {
namespace {

RgbFrame lab_frame() { return Scene(default_lab(), CameraModel{}).render({3.25, 2.0, 0.0}); }

URC::Image image_of(const RgbFrame& frame, URC::ImageEncoding encoding, std::string data) {
  URC::Image image;
  image.mutable_format()->set_width(frame.width);
  image.mutable_format()->set_height(frame.height);
  image.mutable_format()->set_encoding(encoding);
  image.set_data(std::move(data));
  return image;
}

std::string what_of(const URC::Image& image) {
  try {
    to_frame(image);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "(accepted)";
}

TEST(CameraImage, PngRoundTripKeepsEveryPixel) {
  const RgbFrame frame = lab_frame();
  const std::string png = encode_png(frame);
  EXPECT_EQ(png.substr(1, 3), "PNG");
  EXPECT_LT(png.size(), frame.rgb.size()) << "walls and floor are flat: PNG must compress them";
  const RgbFrame back = decode_png(png);
  EXPECT_EQ(back.width, frame.width);
  EXPECT_EQ(back.height, frame.height);
  EXPECT_EQ(back.rgb, frame.rgb);
}

TEST(CameraImage, UrcImagesInBothEncodingsGiveTheSamePixels) {
  const RgbFrame frame = lab_frame();
  const RgbFrame raw = to_frame(image_of(frame, URC::IMAGE_ENCODING_RAW_RGB8, {frame.rgb.begin(), frame.rgb.end()}));
  const RgbFrame png = to_frame(image_of(frame, URC::IMAGE_ENCODING_PNG, encode_png(frame)));
  EXPECT_EQ(raw.rgb, frame.rgb);
  EXPECT_EQ(png.rgb, frame.rgb);
}

TEST(CameraImage, UnreadableImagesAreRefusedByField) {
  const RgbFrame frame = lab_frame();
  EXPECT_EQ(what_of(image_of(frame, URC::IMAGE_ENCODING_RAW_RGB8, "abc")),
            "data: 3 bytes, but a 640x480 RAW_RGB8 image has 921600");
  EXPECT_EQ(what_of(image_of(frame, URC::IMAGE_ENCODING_JPEG, "")),
            "format.encoding: JPEG is not supported (RAW_RGB8 and PNG are)");
  EXPECT_EQ(what_of(image_of(frame, static_cast<URC::ImageEncoding>(9), "")),
            "format.encoding: value 9 (not an ImageEncoding) is not supported (RAW_RGB8 and PNG are)");
  EXPECT_EQ(what_of(image_of(frame, URC::IMAGE_ENCODING_PNG, "not a png")).rfind("not a PNG image: ", 0), 0u);
  URC::Image wrong_size = image_of(frame, URC::IMAGE_ENCODING_PNG, encode_png(frame));
  wrong_size.mutable_format()->set_width(320);
  EXPECT_EQ(what_of(wrong_size), "format: says 320x480 but the PNG data is 640x480");
}

}  // namespace
}  // namespace urs::camera
