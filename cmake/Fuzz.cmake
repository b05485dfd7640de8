# The libFuzzer targets (SWARMSIM_FUZZ=ON, see cmake/Sanitizers.cmake). Included
# from the top-level CMakeLists.txt after the library and the tests are defined.
if(SWARMSIM_FUZZ)
  # coverage instrumentation for the library only; the fuzz targets link libFuzzer
  target_compile_options(swarmsim_lib PRIVATE -fsanitize=fuzzer-no-link)
  add_subdirectory(${PROJECT_SOURCE_DIR}/tests/fuzz ${PROJECT_BINARY_DIR}/fuzz)
endif()
