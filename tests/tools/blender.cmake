# Blender imports a swarmsim run (scripts/blender_import.py) and, re-opening the
# saved .blend without the script, shows the HDF5 positions, ids, velocities and
# obstacles (tests/tools/blender_test.py). Skipped (exit 77) without blender.
# Included from tests/CMakeLists.txt: CMAKE_CURRENT_SOURCE_DIR is tests/.
set(_swarmsim_blender_test "tools: Blender imports a two-swarm run with obstacles")
add_test(NAME "${_swarmsim_blender_test}"
  COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/tools/blender_test.py)
set_tests_properties("${_swarmsim_blender_test}" PROPERTIES
  ENVIRONMENT "${SWARMSIM_TOOL_TEST_ENV}"
  SKIP_RETURN_CODE 77
  TIMEOUT 300)
unset(_swarmsim_blender_test)
