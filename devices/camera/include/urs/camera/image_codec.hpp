#pragma once
// Frame encodings of URC::ImageEncoding: RAW_RGB8 is the frame's own bytes; PNG goes through
// libpng's simplified API (8-bit RGB, no interlace).

#include <string>

#include "urs/camera/scene.hpp"

namespace urs::camera {

std::string encode_png(const RgbFrame& frame);

// Throws std::invalid_argument with libpng's reason if `bytes` is not a PNG image.
RgbFrame decode_png(const std::string& bytes);

}  // namespace urs::camera
