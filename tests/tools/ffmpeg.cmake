# scripts/preview.py --video renders a run to MP4 that ffprobe and ffmpeg read back, and refuses targets it
# must not replace (tests/tools/ffmpeg_test.py). Skipped (exit 77) without ffmpeg.
set(t "tools: ffmpeg reads the MP4 preview of a run, one frame per HDF5 frame")
add_test(NAME "${t}" COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/tools/ffmpeg_test.py)
set_tests_properties("${t}" PROPERTIES ENVIRONMENT "${SWARMSIM_TOOL_TEST_ENV}" SKIP_RETURN_CODE 77 TIMEOUT 300)
