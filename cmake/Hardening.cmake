# Sanitizer and fuzzing builds (docs/reliability.md). Both are off by default: the normal build is
# unchanged. Flags are added before any target exists, so the library, tests and fuzz targets are
# instrumented alike (the Debian libraries they link are not).
set(DOFCACHE_SANITIZE "" CACHE STRING
    "Sanitizers for the library and tests, e.g. address,undefined (empty: none)")
option(DOFCACHE_FUZZ "Build the libFuzzer targets in tests/fuzz (clang only; adds ASan and UBSan)"
       OFF)

if(DOFCACHE_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "DOFCACHE_FUZZ needs clang (libFuzzer): configure with "
                        "-DCMAKE_CXX_COMPILER=clang++")
  endif()
  if(NOT DOFCACHE_SANITIZE)
    set(DOFCACHE_SANITIZE "address,undefined" CACHE STRING "" FORCE)
  endif()
  # Coverage instrumentation everywhere; only the fuzz executables link libFuzzer's main.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()

if(DOFCACHE_SANITIZE)
  add_compile_options(-fsanitize=${DOFCACHE_SANITIZE} -fno-omit-frame-pointer -g)
  add_link_options(-fsanitize=${DOFCACHE_SANITIZE})
  if(DOFCACHE_SANITIZE MATCHES "undefined")
    # A UBSan report must fail the test (or the fuzz run), not scroll past.
    add_compile_options(-fno-sanitize-recover=undefined)
  endif()
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    add_compile_options(-fsanitize-ignorelist=${PROJECT_SOURCE_DIR}/cmake/sanitizer-ignorelist.txt)
  endif()
endif()
