# Finds Tessera's Debian 12 dependencies and wraps them in imported targets.
# OpenColorIO 2.1 ships no CMake config and OpenImageIO's config references a missing OpenCV
# include directory on Debian 12, so both come through pkg-config.
find_package(PkgConfig REQUIRED)
find_package(Threads REQUIRED)
find_package(TBB REQUIRED)
find_package(embree 3 REQUIRED)
pkg_check_modules(OIIO REQUIRED IMPORTED_TARGET OpenImageIO)
pkg_check_modules(OCIO REQUIRED IMPORTED_TARGET OpenColorIO)
# Debian 12's Imath export (pulled in by OpenEXR's config) lists Imath::PyImath_Python3_11, whose
# library is in a Python package Tessera does not use; CMake's import check then prints a
# STATUS block about the missing file in the middle of every configure. The check is only that
# status text (the target is never linked), so status messages are muted while OpenEXR and
# Imath are found; errors and warnings still print.
set(_tessera_log_level "${CMAKE_MESSAGE_LOG_LEVEL}")
set(CMAKE_MESSAGE_LOG_LEVEL NOTICE)
find_package(OpenEXR REQUIRED)
set(CMAKE_MESSAGE_LOG_LEVEL "${_tessera_log_level}")
message(STATUS "Found OpenEXR ${OpenEXR_VERSION}")
find_package(tinyobjloader REQUIRED)
find_package(ZLIB REQUIRED)
find_package(nlohmann_json 3 REQUIRED)
find_package(CLI11 QUIET CONFIG)
if(NOT TARGET CLI11::CLI11)
  add_library(CLI11::CLI11 INTERFACE IMPORTED)
endif()
if(TESSERA_BUILD_TESTS)
  find_package(doctest REQUIRED)
endif()
if(TESSERA_BUILD_BENCHMARKS)
  find_package(benchmark REQUIRED)
  # Only bench_ply uses assimp (Tessera's PLY reader against assimp's); without it that
  # benchmark runs Tessera's reader alone.
  find_package(assimp QUIET)
endif()
