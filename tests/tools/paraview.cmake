# ParaView (pvpython) reads `swarmsim export` output: tests/tools/paraview_test.py
set(t "tools: ParaView opens the XDMF and PLY export of a two-swarm run with obstacles")
add_test(NAME "${t}" COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/tools/paraview_test.py)
set_tests_properties("${t}" PROPERTIES ENVIRONMENT "${SWARMSIM_TOOL_TEST_ENV}" SKIP_RETURN_CODE 77 TIMEOUT 300)
# pvbatch renders frames of the export (scripts/paraview_render.py): tests/tools/paraview_render_test.py
set(t "tools: ParaView's pvbatch renders frames of the XDMF export")
add_test(NAME "${t}" COMMAND /usr/bin/python3 ${CMAKE_CURRENT_SOURCE_DIR}/tools/paraview_render_test.py)
set_tests_properties("${t}" PROPERTIES ENVIRONMENT "${SWARMSIM_TOOL_TEST_ENV}" SKIP_RETURN_CODE 77 TIMEOUT 300)
