#include "urs/camera/recognizer.hpp"

#include <zbar.h>

#include <algorithm>
#include <stdexcept>
#include <string>

#include "urs/camera/image_codec.hpp"
#include "urs_options.pb.h"

namespace urs::camera {
namespace {

// ZBar lists a QR symbol's location points counter-clockwise from its top-left (top-left,
// bottom-left, bottom-right, top-right); URC wants them clockwise from the top-left.
constexpr int kClockwiseFromZbar[4] = {0, 3, 2, 1};

std::string grey(const RgbFrame& frame) {
  std::string y800(static_cast<size_t>(frame.width) * frame.height, '\0');
  for (size_t i = 0; i < y800.size(); ++i) {
    const std::uint8_t* p = &frame.rgb[i * 3];
    y800[i] = static_cast<char>((299 * p[0] + 587 * p[1] + 114 * p[2] + 500) / 1000);  // ITU-R BT.601 luma
  }
  return y800;
}

}  // namespace

std::vector<URC::Marker> find_markers(const RgbFrame& frame) {
  const std::string y800 = grey(frame);
  zbar::ImageScanner scanner;
  scanner.set_config(zbar::ZBAR_NONE, zbar::ZBAR_CFG_ENABLE, 0);
  scanner.set_config(zbar::ZBAR_QRCODE, zbar::ZBAR_CFG_ENABLE, 1);
  zbar::Image image(frame.width, frame.height, "Y800", y800.data(), y800.size());
  scanner.scan(image);

  std::vector<URC::Marker> markers;
  for (auto symbol = image.symbol_begin(); symbol != image.symbol_end(); ++symbol) {
    if (symbol->get_location_size() != 4) continue;  // QR symbols always have 4; anything else is not ours
    URC::Marker marker;
    marker.set_content(symbol->get_data());
    unsigned left = frame.width, top = frame.height, right = 0, bottom = 0;
    for (int corner : kClockwiseFromZbar) {
      const int x = symbol->get_location_x(corner), y = symbol->get_location_y(corner);
      auto* point = marker.add_corners();
      point->set_x(static_cast<float>(x));
      point->set_y(static_cast<float>(y));
      left = std::min(left, static_cast<unsigned>(std::max(x, 0)));
      top = std::min(top, static_cast<unsigned>(std::max(y, 0)));
      right = std::max(right, static_cast<unsigned>(std::max(x, 0)));
      bottom = std::max(bottom, static_cast<unsigned>(std::max(y, 0)));
    }
    marker.mutable_bbox()->set_x(left);
    marker.mutable_bbox()->set_y(top);
    marker.mutable_bbox()->set_width(right - left);
    marker.mutable_bbox()->set_height(bottom - top);
    marker.set_confidence(std::clamp(static_cast<float>(symbol->get_quality()), 0.0f, 1.0f));
    markers.push_back(std::move(marker));
  }
  auto area = [](const URC::Marker& m) { return uint64_t{m.bbox().width()} * m.bbox().height(); };
  std::stable_sort(markers.begin(), markers.end(), [&](const URC::Marker& a, const URC::Marker& b) {
    return a.confidence() != b.confidence() ? a.confidence() > b.confidence() : area(a) > area(b);
  });
  return markers;
}

std::string encoding_name(int encoding) {
  if (!URC::ImageEncoding_IsValid(encoding)) return "value " + std::to_string(encoding) + " (not an ImageEncoding)";
  const auto* value = URC::ImageEncoding_descriptor()->FindValueByNumber(encoding);
  return value->options().GetExtension(urs::options::idl_enumerator);
}

RgbFrame to_frame(const URC::Image& image) {
  const auto& format = image.format();
  switch (format.encoding()) {
    case URC::IMAGE_ENCODING_RAW_RGB8: {
      const uint64_t expected = uint64_t{format.width()} * format.height() * 3;
      if (image.data().size() != expected) {
        throw std::invalid_argument("data: " + std::to_string(image.data().size()) + " bytes, but a " +
                                    std::to_string(format.width()) + "x" + std::to_string(format.height()) +
                                    " RAW_RGB8 image has " + std::to_string(expected));
      }
      RgbFrame frame{format.width(), format.height(), {}};
      frame.rgb.assign(image.data().begin(), image.data().end());
      return frame;
    }
    case URC::IMAGE_ENCODING_PNG: {
      RgbFrame frame = decode_png(image.data());
      if (frame.width != format.width() || frame.height != format.height()) {
        throw std::invalid_argument("format: says " + std::to_string(format.width()) + "x" +
                                    std::to_string(format.height()) + " but the PNG data is " +
                                    std::to_string(frame.width) + "x" + std::to_string(frame.height));
      }
      return frame;
    }
    default:
      throw std::invalid_argument("format.encoding: " + encoding_name(format.encoding()) +
                                  " is not supported (RAW_RGB8 and PNG are)");
  }
}

}  // namespace urs::camera
