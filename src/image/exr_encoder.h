#pragma once
// The EXR encoder behind write_image and encode_exr (exr_encoder.cpp).
#include <map>
#include <string>
#include <vector>

#include "dofcache/image/image_io.h"

namespace dofcache::image {

// `color` and `extra` as the bytes of a float, ZIP-compressed EXR file, with `attributes` in its
// header as "dofcache:<key>" strings. Throws dofcache::Error "<context>: <reason>" for bad
// channels or a failed encode.
std::vector<unsigned char> exr_bytes(const Image& color, const std::vector<NamedChannels>& extra,
                                     const std::string& context,
                                     const std::map<std::string, std::string>& attributes = {});

}  // namespace dofcache::image
