# Debian's scikit-fmm and our fast marching side by side on 64^3 grids (scripts/fmm_compare.py --check):
# our second order at least as accurate as scikit-fmm's on a smooth solution (times are printed, not
# checked). Skipped (exit 77) without python3-scikit-fmm.
set(t "tools: scikit-fmm and our fast marching side by side at 64^3")
add_test(NAME "${t}" COMMAND /usr/bin/python3 ${PROJECT_SOURCE_DIR}/scripts/fmm_compare.py --sizes 64 --repeat 3
         --check --fmm-bench $<TARGET_FILE:fmm_bench>)
set_tests_properties("${t}" PROPERTIES ENVIRONMENT "${SWARMSIM_TOOL_TEST_ENV}" SKIP_RETURN_CODE 77 TIMEOUT 300)
