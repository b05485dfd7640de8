# Optional instrumented builds (docs/testing.md). Both options are OFF by
# default; the default build does not change.
#
#   SWARMSIM_SANITIZE=ON  AddressSanitizer + UndefinedBehaviorSanitizer for every
#                         target (library, CLI, tests); any UBSan report aborts
#                         (-fno-sanitize-recover=undefined). GCC or Clang.
#   SWARMSIM_FUZZ=ON      also the libFuzzer targets of tests/fuzz/ (Clang only,
#                         needs libFuzzer: Debian's libfuzzer-<version>-dev).
#                         Implies SWARMSIM_SANITIZE. The library is compiled with
#                         -fsanitize=fuzzer-no-link (coverage for the fuzzers);
#                         the sanitized tests and the CLI link it without libFuzzer,
#                         so one build directory serves both.
#
# Included from the top-level CMakeLists.txt before the targets are defined;
# cmake/Fuzz.cmake (included after them) adds the fuzz targets.

option(SWARMSIM_SANITIZE "Build everything with ASan + UBSan" OFF)
option(SWARMSIM_FUZZ "Add the libFuzzer targets in tests/fuzz (Clang; implies SWARMSIM_SANITIZE)" OFF)

if(SWARMSIM_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "SWARMSIM_FUZZ=ON needs Clang (libFuzzer); configure with -DCMAKE_CXX_COMPILER=clang++ "
                        "-DCMAKE_C_COMPILER=clang (scripts/fuzz.sh does)")
  endif()
  set(SWARMSIM_SANITIZE ON)
endif()

if(SWARMSIM_SANITIZE)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang|GNU")
    message(FATAL_ERROR "SWARMSIM_SANITIZE=ON needs GCC or Clang")
  endif()
  set(SWARMSIM_SANITIZER_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=undefined)
  # frame pointers and line tables: readable sanitizer stack traces at little build cost
  add_compile_options(${SWARMSIM_SANITIZER_FLAGS} -fno-omit-frame-pointer
                      $<IF:$<COMPILE_LANG_AND_ID:CXX,Clang>,-gline-tables-only,-g1>)
  add_link_options(${SWARMSIM_SANITIZER_FLAGS})
  # a sanitized test runs several times slower: a longer CTest timeout per test
  # case (used by tests/CMakeLists.txt; -DSWARMSIM_TEST_TIMEOUT=... overrides)
  if(NOT DEFINED SWARMSIM_TEST_TIMEOUT)
    set(SWARMSIM_TEST_TIMEOUT 900)
  endif()
  message(STATUS "swarmsim: ASan + UBSan build (fuzz targets: ${SWARMSIM_FUZZ})")
endif()
