#pragma once
// Marker recognition: QR symbols found by ZBar in a frame's grey (Y800) version.

#include <string>
#include <vector>

#include "ImageRecognition.pb.h"
#include "urs/camera/scene.hpp"

namespace urs::camera {

// Markers found in `frame`, most confident first (ties: the larger on screen first). Corners are
// clockwise from the symbol's own top-left corner, bbox is the box around them. Confidence is
// ZBar's quality clamped to 0..1: a QR symbol that decodes has passed its error correction, so
// ZBar reports it as certain (1).
std::vector<URC::Marker> find_markers(const RgbFrame& frame);

// The pixels of an URC image; throws std::invalid_argument naming the field that is wrong
// (unsupported encoding, size that does not match the format, bytes that do not decode).
RgbFrame to_frame(const URC::Image& image);

// The IDL name of an URC::ImageEncoding value ("PNG"), or words saying it is not one.
std::string encoding_name(int encoding);

}  // namespace urs::camera
