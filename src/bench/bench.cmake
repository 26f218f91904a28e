# cbdpt-bench: traversal, build, render, scaling and accumulation benchmarks, one source per
# section. Embree 3 is an optional baseline: without it the traversal table has our numbers only.
find_package(embree 3 QUIET)
add_executable(cbdpt-bench
  ${CMAKE_SOURCE_DIR}/src/bench/bench_main.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_common.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_rays.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_traverse.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_build.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_render.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_scaling.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_accumulate.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/bench_meshes.cpp
  ${CMAKE_SOURCE_DIR}/src/bench/embree_baseline.cpp)
target_link_libraries(cbdpt-bench PRIVATE cbdpt_core CLI11::CLI11)
if(embree_FOUND)
  target_compile_definitions(cbdpt-bench PRIVATE CBDPT_HAVE_EMBREE=1)
  target_link_libraries(cbdpt-bench PRIVATE embree)
  message(STATUS "cbdpt-bench: Embree ${embree_VERSION} baseline enabled")
else()
  message(STATUS "cbdpt-bench: Embree 3 not found, no baseline (apt-get install libembree-dev)")
endif()
