// 8-bit sRGB PNG encoding with libpng, in the image library itself rather than the codec module:
// the default output of a render is a PNG, and writing it should not cost the ~0.4 CPU-seconds of
// loading OpenImageIO and the libraries it links (codec_module.h), a third of a quick preview.
#include <csetjmp>
#include <string>
#include <vector>

#include <png.h>

#include "dofcache/core/error.h"
#include "dofcache/image/image_io.h"

namespace dofcache::image {
namespace {

// libpng reports errors by longjmp; the message is kept for the one-line error.
struct Sink {
  std::vector<unsigned char>* bytes;
  std::string error;
};

void write_bytes(png_structp png, png_bytep data, png_size_t length) {
  auto* sink = static_cast<Sink*>(png_get_io_ptr(png));
  sink->bytes->insert(sink->bytes->end(), data, data + length);
}

void flush_bytes(png_structp) {}

void on_error(png_structp png, png_const_charp message) {
  auto* sink = static_cast<Sink*>(png_get_error_ptr(png));
  sink->error = message ? message : "libpng error";
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}

}  // namespace

std::vector<unsigned char> encode_png(const Image& color) {
  if (color.empty() || color.channels() != 3)
    throw Error("cannot encode a PNG image: colour must be a non-empty RGB image");
  // 8-bit sRGB, rounded to nearest; linear_to_srgb clamps to [0, 1] and maps NaN to 0.
  const std::vector<float>& src = color.data();
  std::vector<unsigned char> pixels(src.size());
  for (std::size_t i = 0; i < src.size(); ++i)
    pixels[i] = static_cast<unsigned char>(std::lround(linear_to_srgb(src[i]) * 255.0f));

  std::vector<unsigned char> bytes;
  Sink sink{&bytes, {}};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, on_error, on_warning);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!png || !info) {
    png_destroy_write_struct(&png, nullptr);
    throw Error("cannot encode a PNG image: out of memory");
  }
  std::vector<png_bytep> rows(static_cast<std::size_t>(color.height()));
  for (int y = 0; y < color.height(); ++y)
    rows[static_cast<std::size_t>(y)] =
        pixels.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(color.width()) * 3;
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    throw Error("cannot encode a PNG image: " + sink.error);
  }
  png_set_write_fn(png, &sink, write_bytes, flush_bytes);
  png_set_IHDR(png, info, static_cast<png_uint_32>(color.width()),
               static_cast<png_uint_32>(color.height()), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_set_rows(png, info, rows.data());
  png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  png_destroy_write_struct(&png, &info);
  return bytes;
}

}  // namespace dofcache::image
