# The instruction set Tessera's own code is compiled for (third-party libraries bring their own:
# Embree picks its kernels at run time).
#
#   TESSERA_ISA=auto      (default) x86-64-v3 (AVX2, FMA, BMI2: Intel Haswell, AMD Zen and later)
#                         when the compiler accepts it and the build machine runs it; otherwise
#                         the compiler's default. The binary is then for machines like this one.
#   TESSERA_ISA=default   no -march flag: a binary that runs on any x86-64.
#   TESSERA_ISA=<level>   -march=<level> as given (x86-64-v2, x86-64-v4, native, ...).
#
# Every build also gets -ffp-contract=off: the compiler may not fuse a*b+c into an FMA on its own.
# Contraction would make results depend on how each function happened to be inlined, and the
# specialised code paths must render the general path's image bit for bit
# (tests/renderer/test_specialize.cpp). With it off, the x86-64-v3 build renders the same images
# as the default build, bit for bit.
set(TESSERA_ISA "auto" CACHE STRING
    "Instruction set for Tessera's code: auto, default, or a -march level such as x86-64-v3")

target_compile_options(tessera_flags INTERFACE -ffp-contract=off)

set(_tessera_march "")
if(TESSERA_ISA STREQUAL "auto")
  if(NOT CMAKE_CROSSCOMPILING AND CMAKE_SYSTEM_PROCESSOR MATCHES "^(x86_64|AMD64|amd64)$")
    include(CheckCXXCompilerFlag)
    check_cxx_compiler_flag(-march=x86-64-v3 TESSERA_COMPILER_HAS_X86_64_V3)
    if(TESSERA_COMPILER_HAS_X86_64_V3)
      set(_probe ${CMAKE_BINARY_DIR}/CMakeFiles/tessera_isa_probe.cpp)
      file(WRITE ${_probe} [=[
int main() {
    __builtin_cpu_init();
    bool v3 = __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
              __builtin_cpu_supports("bmi2") && __builtin_cpu_supports("movbe");
    return v3 ? 0 : 1;
}
]=])
      try_run(TESSERA_HOST_RUNS_X86_64_V3 _tessera_probe_compiled
              ${CMAKE_BINARY_DIR}/CMakeFiles/tessera_isa_probe ${_probe})
      if(_tessera_probe_compiled AND TESSERA_HOST_RUNS_X86_64_V3 EQUAL 0)
        set(_tessera_march "x86-64-v3")
      endif()
    endif()
  endif()
elseif(NOT TESSERA_ISA STREQUAL "default")
  set(_tessera_march "${TESSERA_ISA}")
endif()

if(_tessera_march)
  target_compile_options(tessera_flags INTERFACE -march=${_tessera_march})
  message(STATUS "Tessera: compiling for -march=${_tessera_march} (TESSERA_ISA=${TESSERA_ISA})")
else()
  message(STATUS "Tessera: compiling for the compiler's default instruction set "
                 "(TESSERA_ISA=${TESSERA_ISA})")
endif()
