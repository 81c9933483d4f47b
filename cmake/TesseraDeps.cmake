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
find_package(PNG REQUIRED)
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

# Distributed rendering on MPI (renderer/app/mpi_group.h): AUTO builds it in when Debian's
# libopenmpi-dev is present (scripts/setup.sh installs it), ON requires it, OFF leaves it out.
set(TESSERA_MPI AUTO CACHE STRING "Distributed rendering on MPI: AUTO, ON or OFF")
set_property(CACHE TESSERA_MPI PROPERTY STRINGS AUTO ON OFF)
set(TESSERA_WITH_MPI OFF)
if(NOT TESSERA_MPI STREQUAL "OFF")
  # The C API from C++ (the project enables no C compiler); without the deprecated C++ bindings.
  set(MPI_CXX_SKIP_MPICXX ON)
  find_package(MPI COMPONENTS CXX QUIET)
  if(MPI_CXX_FOUND)
    set(TESSERA_WITH_MPI ON)
    message(STATUS "Distributed rendering: MPI ${MPI_CXX_VERSION} (${MPI_CXX_LIBRARIES})")
  elseif(TESSERA_MPI STREQUAL "ON")
    message(FATAL_ERROR "TESSERA_MPI=ON but no MPI was found (apt-get install libopenmpi-dev)")
  else()
    message(STATUS "Distributed rendering: no MPI found, built without it")
  endif()
endif()
