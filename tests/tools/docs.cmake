# The Python and shell examples of docs/tools.md run as written (tests/tools/docs_python_test.py).
set(t "tools: the Python and shell examples of docs/tools.md run")
add_test(NAME "${t}" COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/tools/docs_python_test.py)
set_tests_properties("${t}" PROPERTIES ENVIRONMENT "${SWARMSIM_TOOL_TEST_ENV}" SKIP_RETURN_CODE 77 TIMEOUT 300)
