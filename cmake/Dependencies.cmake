# All dependencies come from Debian 12 packages. Order matters: TBB must be found (CONFIG)
# before OpenVDB's module path is added, or OpenVDB's FindTBB takes over and targets clash.
find_package(TBB CONFIG REQUIRED)
find_package(embree 3.13 CONFIG REQUIRED)
find_package(OpenImageIO 2.4 CONFIG REQUIRED)
find_package(glm CONFIG REQUIRED)
find_package(TinyGLTF CONFIG REQUIRED)
find_package(nlohmann_json 3 CONFIG REQUIRED)
find_package(CLI11 CONFIG REQUIRED)
find_package(fmt CONFIG REQUIRED)
find_package(Threads REQUIRED)
# libpng: the PNG output is encoded without loading OpenImageIO (src/image/png_encoder.cpp).
find_package(PNG REQUIRED)
# OpenEXR: EXR output is encoded without loading OpenImageIO (src/image/exr_encoder.cpp).
find_package(OpenEXR 3 CONFIG REQUIRED)
# zlib: PNG textures are inflated once before stb_image decodes them (src/scene/gltf_document.cpp).
find_package(ZLIB REQUIRED)
if(DOFCACHE_BUILD_TESTS)
  find_package(GTest CONFIG REQUIRED)
endif()
if(DOFCACHE_BUILD_BENCH)
  find_package(benchmark CONFIG REQUIRED)
endif()

# OpenVDB ships only a Find module (no config package).
list(APPEND CMAKE_MODULE_PATH /usr/lib/x86_64-linux-gnu/cmake/OpenVDB)
find_package(OpenVDB 10 REQUIRED)

# Debian's OpenImageIO target names /usr/include/opencv4 as an include directory even when OpenCV
# is not installed, which makes CMake refuse to generate. We do not use OpenCV: drop the entry.
foreach(prop INTERFACE_INCLUDE_DIRECTORIES INTERFACE_SYSTEM_INCLUDE_DIRECTORIES)
  get_target_property(dirs OpenImageIO::OpenImageIO ${prop})
  if(dirs)
    list(FILTER dirs EXCLUDE REGEX "opencv4")
    set_target_properties(OpenImageIO::OpenImageIO PROPERTIES ${prop} "${dirs}")
  endif()
endforeach()
