# One doctest binary for the fast suites; statistical (slow) suites carry the doctest
# decorator `* doctest::test_suite("statistical")` and get the CTest label "statistical".
include(${doctest_DIR}/doctest.cmake)
file(GLOB CBDPT_TEST_SOURCES CONFIGURE_DEPENDS ${CMAKE_SOURCE_DIR}/tests/*.cpp)
add_executable(cbdpt_tests ${CBDPT_TEST_SOURCES})
target_link_libraries(cbdpt_tests PRIVATE cbdpt_core doctest::doctest)
# The test files at -O1 compile in about 60% of -O3's time (docs/code-tour.md); what they test,
# cbdpt_core and the kernel headers' host instances, stays built as shipped.
if(CMAKE_BUILD_TYPE STREQUAL "Release")
  target_compile_options(cbdpt_tests PRIVATE -O1)
endif()
target_precompile_headers(cbdpt_tests PRIVATE <doctest/doctest.h> <fmt/format.h> <algorithm> <array>
  <cmath> <cstdint> <cstdlib> <filesystem> <fstream> <functional> <map> <memory> <optional>
  <random> <sstream> <stdexcept> <string> <vector>)
# test_main.cpp defines doctest's main before including it.
set_source_files_properties(${CMAKE_SOURCE_DIR}/tests/test_main.cpp PROPERTIES
                            SKIP_PRECOMPILE_HEADERS ON)
# A kernel that loops forever (a broken traversal does) fails after 10 minutes, not CTest's 25.
# Tests that need the Stanford models read them from CBDPT_MODEL_PATH; without them they print
# "cbdpt-skip:" and CTest counts them as skipped (tests/stanford_models.h; CI fails instead).
# A sanitized build's cases run from scripts/run-sanitized-tests, not CTest: listing them (one
# instrumented process per case, for its labels) would add 15 s to that build.
if(NOT CBDPT_SANITIZE)
  doctest_discover_tests(cbdpt_tests ADD_LABELS 1 PROPERTIES ENVIRONMENT "CBDPT_SOURCE_DIR=${CMAKE_SOURCE_DIR}"
                         TIMEOUT 600 SKIP_REGULAR_EXPRESSION "cbdpt-skip:")
endif()

# End-to-end tests of the command line (render, interrupt, errors, info).
add_test(NAME cli COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_cli.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})

# scripts/make-big-scene (a scene whose tree outgrows the cache, for the prefetch's numbers)
# writes a scene that renders.
add_test(NAME big_scene COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_big_scene.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})

# The image lights' comparison images are scripts/make-sky's (docs/pbrt-v4.md).
add_test(NAME sky_reproducible COMMAND python3 ${CMAKE_SOURCE_DIR}/scripts/make-sky --check
         ${CMAKE_SOURCE_DIR}/scenes/pbrt-v4/textures/sky.exr)
add_test(NAME beam_reproducible COMMAND python3 ${CMAKE_SOURCE_DIR}/scripts/make-sky --check
         ${CMAKE_SOURCE_DIR}/scenes/pbrt-v4/textures/beam.exr --size 64 --sun 20)
add_test(NAME textures_reproducible COMMAND python3 ${CMAKE_SOURCE_DIR}/scripts/make-texture --check
         ${CMAKE_SOURCE_DIR}/scenes/pbrt-v4/textures)

# Thesis scene data: the grille/cage/lamp PLYs reproduce byte for byte from
# scripts/make-meshes, are closed and outward, match docs/scenes.md, and every scene file
# references existing files and keeps its objects and lights inside the Cornell box.
add_test(NAME meshes_reproducible COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_meshes.py)
set_tests_properties(meshes_reproducible PROPERTIES
                     ENVIRONMENT "CBDPT_SOURCE_DIR=${CMAKE_SOURCE_DIR}")

# cbdpt-bench --quick runs and writes well-formed JSON; no timing assertions. It finds the
# Stanford models through CBDPT_MODEL_PATH, inherited from the caller.
if(TARGET cbdpt-bench)
  add_test(NAME bench_quick COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_bench.py $<TARGET_FILE:cbdpt-bench>)
  set_tests_properties(bench_quick PROPERTIES TIMEOUT 900 SKIP_REGULAR_EXPRESSION "cbdpt-skip:")
  # The packet traversal prototypes find the wide traversal's and Embree's hits.
  add_test(NAME bench_packet COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_bench_packet.py $<TARGET_FILE:cbdpt-bench>)
  set_tests_properties(bench_packet PROPERTIES TIMEOUT 900 SKIP_REGULAR_EXPRESSION "cbdpt-skip:")
  # scripts/interleave-traverse runs each entry's traversal and lists its rows.
  add_test(NAME interleave_traverse COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_interleave_traverse.py $<TARGET_FILE:cbdpt-bench> ${CMAKE_SOURCE_DIR})
  set_tests_properties(interleave_traverse PROPERTIES TIMEOUT 600 SKIP_REGULAR_EXPRESSION "cbdpt-skip:")
endif()

# Error against time: checkpoints, logs, compare, experiment --quick -> report.
add_test(NAME checkpoints COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_checkpoints.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(checkpoints PROPERTIES TIMEOUT 600)

# scripts/interleave-render, the render timings of docs/performance.md: one tiny round.
add_test(NAME interleave_render COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_interleave_render.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(interleave_render PROPERTIES TIMEOUT 600)

# scripts/report's combination section on synthetic units with known answers: the single
# methods at equal CPU time, the goal reached, not reached, not measured.
add_test(NAME report_combine COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_report_combine.py ${CMAKE_SOURCE_DIR})
set_tests_properties(report_combine PROPERTIES TIMEOUT 600)
# scripts/equal-time-pbrt --regions finds known per-cell variances (no pbrt-v4 needed); the
# comparison scripts' refusals.
add_test(NAME equal_time_regions COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_equal_time_regions.py ${CMAKE_SOURCE_DIR})
# scripts/compare-mitsuba without Mitsuba: its scene reader against cbdpt info, its colour
# matrices against docs/spectral.md, refusals naming file and line, the error at equal time.
add_test(NAME compare_mitsuba COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_compare_mitsuba.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(compare_mitsuba PROPERTIES TIMEOUT 300)
# The comparison scripts' arithmetic (emitter mask, FLIP) and refusals, with stand-in renderers.
add_test(NAME comparison_scripts COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_comparison_scripts.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(comparison_scripts PROPERTIES TIMEOUT 300)
# scripts/named-spectra on a small database: the table it writes, --check, its refusals.
add_test(NAME named_spectra COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_named_spectra.py ${CMAKE_SOURCE_DIR})
# pbrt-v4's named illuminants are colour-science's CIE tables (docs/pbrt-v4.md, "Named spectra").
add_test(NAME named_illuminants COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_named_illuminants.py ${CMAKE_SOURCE_DIR})
add_test(NAME camera_sensors COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_camera_sensors.py ${CMAKE_SOURCE_DIR})
# Every repository path the README and docs/ name exists (docs describe the present).
add_test(NAME docs_paths COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_docs_paths.py ${CMAKE_SOURCE_DIR})
# PoCL's default work-group method and "loops" compile the kernels into the same images
# (a compiler check, docs/robustness.md section 5).
add_test(NAME work_group_methods COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_work_group_methods.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(work_group_methods PROPERTIES TIMEOUT 600 SKIP_REGULAR_EXPRESSION "cbdpt-skip:")
# pyflakes finds nothing in the Python of scripts/ and tests/ (warnings on, no warnings).
add_test(NAME python_lint COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_python_lint.py ${CMAKE_SOURCE_DIR})
# scripts/report's answers to the thesis's claims on synthetic units with known cost and error
# ratios: bands apart and overlapping, each claim's count of where it holds.
add_test(NAME report_claims COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_report_claims.py ${CMAKE_SOURCE_DIR})
set_tests_properties(report_claims PROPERTIES TIMEOUT 600)

# cbdpt combine (docs/combine.md): render records, halves, combinations, --split-budget, refusals.
add_test(NAME combine_cli COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_combine_cli.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(combine_cli PROPERTIES TIMEOUT 600)
# scripts/gpu-check (docs/gpu.md) on the CPU device: every method rendered in its own process,
# the doctest cases one process each.
add_test(NAME gpu_check COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_gpu_check.py $<TARGET_FILE:cbdpt> $<TARGET_FILE:cbdpt_tests> ${CMAKE_SOURCE_DIR})
set_tests_properties(gpu_check PROPERTIES TIMEOUT 600 SKIP_REGULAR_EXPRESSION "cbdpt-skip:")
# scripts/gpu-bundle: what the GPU check needs on a machine without build tools.
add_test(NAME gpu_bundle COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_gpu_bundle.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(gpu_bundle PROPERTIES TIMEOUT 120)
# Renders that scale and survive: shards merged bit for bit (PT, CPT, BDPT, CBDPT), SIGKILL and
# --resume from the periodic state, output checks and kept work, corrupted states refused.
add_test(NAME scale COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_scale.py $<TARGET_FILE:cbdpt> ${CMAKE_SOURCE_DIR})
set_tests_properties(scale PROPERTIES TIMEOUT 900)
# The same estimates rendered by 2 MPI ranks equal the single-process render (MPI builds only).
if(MPI_CXX_FOUND AND MPIEXEC_EXECUTABLE)
  add_test(NAME scale_mpi COMMAND python3 ${CMAKE_SOURCE_DIR}/tests/test_scale.py $<TARGET_FILE:cbdpt>
           ${CMAKE_SOURCE_DIR} --mpi "${MPIEXEC_EXECUTABLE} --oversubscribe --allow-run-as-root")
  set_tests_properties(scale_mpi PROPERTIES TIMEOUT 900)
endif()
