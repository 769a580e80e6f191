#include "urs/camera/image_codec.hpp"

#include <png.h>

#include <stdexcept>

namespace urs::camera {

std::string encode_png(const RgbFrame& frame) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  image.width = frame.width;
  image.height = frame.height;
  image.format = PNG_FORMAT_RGB;
  png_alloc_size_t size = 0;
  const png_int_32 stride = static_cast<png_int_32>(frame.width * 3);
  // First call sizes the output, second fills it (libpng's documented two-pass use).
  if (!png_image_write_to_memory(&image, nullptr, &size, 0, frame.rgb.data(), stride, nullptr)) {
    throw std::runtime_error(std::string("PNG encoding failed: ") + image.message);
  }
  std::string out(size, '\0');
  if (!png_image_write_to_memory(&image, out.data(), &size, 0, frame.rgb.data(), stride, nullptr)) {
    throw std::runtime_error(std::string("PNG encoding failed: ") + image.message);
  }
  out.resize(size);
  return out;
}

RgbFrame decode_png(const std::string& bytes) {
  png_image image{};
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size())) {
    throw std::invalid_argument(std::string("not a PNG image: ") + image.message);
  }
  image.format = PNG_FORMAT_RGB;
  RgbFrame frame{image.width, image.height, {}};
  frame.rgb.resize(PNG_IMAGE_SIZE(image));
  if (!png_image_finish_read(&image, nullptr, frame.rgb.data(), 0, nullptr)) {
    png_image_free(&image);
    throw std::invalid_argument(std::string("PNG image cannot be decoded: ") + image.message);
  }
  return frame;
}

}  // namespace urs::camera
