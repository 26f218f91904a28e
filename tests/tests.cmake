# One doctest binary for the fast suites; statistical (slow) suites carry the doctest
# decorator `* doctest::test_suite("statistical")` and get the CTest label "statistical".
include(${doctest_DIR}/doctest.cmake)
file(GLOB CBDPT_TEST_SOURCES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/*.cpp)
add_executable(cbdpt_tests ${CBDPT_TEST_SOURCES})
target_link_libraries(cbdpt_tests PRIVATE cbdpt_core doctest::doctest)
target_compile_definitions(cbdpt_tests PRIVATE CBDPT_MODELS_DIR="${CMAKE_SOURCE_DIR}/../shared/models")
# A kernel that loops forever (a broken traversal does) fails after 10 minutes, not CTest's 25.
doctest_discover_tests(cbdpt_tests ADD_LABELS 1 PROPERTIES ENVIRONMENT "CBDPT_SOURCE_DIR=${CMAKE_SOURCE_DIR}"
                       TIMEOUT 600)

# End-to-end tests of the command line (render, interrupt, errors, info).
add_test(NAME cli COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_cli.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})

# Thesis scene data (issue 3): the grille/cage/lamp PLYs reproduce byte for byte from
# scripts/make-meshes, are closed and outward, match docs/scenes.md, and every scene file
# references existing files and keeps its objects and lights inside the Cornell box.
add_test(NAME meshes_reproducible COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_meshes.py)
set_tests_properties(meshes_reproducible PROPERTIES
                     ENVIRONMENT "CBDPT_SOURCE_DIR=${CMAKE_SOURCE_DIR}")

# cbdpt-bench --quick runs and writes well-formed JSON (issue 9); no timing assertions.
if(TARGET cbdpt-bench)
  add_test(NAME bench_quick COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_bench.py $<TARGET_FILE:cbdpt-bench>)
  # The caller's CBDPT_MODEL_PATH first, then the default beside the source tree.
  set_tests_properties(bench_quick PROPERTIES TIMEOUT 900
                       ENVIRONMENT_MODIFICATION
                       "CBDPT_MODEL_PATH=path_list_append:${CMAKE_SOURCE_DIR}/../shared/models")
endif()

# Error against time (issue 7): checkpoints, logs, compare, experiment --quick -> report.
add_test(NAME checkpoints COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_checkpoints.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(checkpoints PROPERTIES TIMEOUT 600)
