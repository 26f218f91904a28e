# libFuzzer targets for the scene parser and the PLY reader (docs/robustness.md). Included from
# the root CMakeLists.txt when CBDPT_FUZZ=ON; scripts/fuzz configures and runs them.
# Only the parser's sources and the file, image, NanoVDB and spectra reading they use are
# compiled, instrumented for coverage, so the fuzz build needs neither OpenCL nor the rest of
# cbdpt_core.
if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
  message(FATAL_ERROR "CBDPT_FUZZ=ON needs clang (libFuzzer), e.g. CC=clang-14 CXX=clang++-14")
endif()
set(CBDPT_FUZZ_FLAGS -fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all
                     -fno-omit-frame-pointer -g)
add_library(cbdpt_fuzz_scene OBJECT ${CMAKE_SOURCE_DIR}/src/scene/parser.cpp
                                    ${CMAKE_SOURCE_DIR}/src/scene/loop_subdivision.cpp
                                    ${CMAKE_SOURCE_DIR}/src/scene/nanovdb.cpp
                                    ${CMAKE_SOURCE_DIR}/src/scene/ply.cpp
                                    ${CMAKE_SOURCE_DIR}/src/scene/scene_error.cpp
                                    ${CMAKE_SOURCE_DIR}/src/io/files.cpp
                                    ${CMAKE_SOURCE_DIR}/src/image/image.cpp
                                    ${CMAKE_SOURCE_DIR}/src/spectral/camera_sensors.cpp
                                    ${CMAKE_SOURCE_DIR}/src/spectral/camera_sensors_data.cpp
                                    ${CMAKE_SOURCE_DIR}/src/spectral/named_spectra.cpp
                                    ${CMAKE_SOURCE_DIR}/src/spectral/named_spectra_data.cpp
                                    ${CMAKE_SOURCE_DIR}/src/spectral/named_illuminants_data.cpp
                                    ${CMAKE_SOURCE_DIR}/src/spectral/spectral.cpp)
# kernels/: the parser computes an image light's illuminance through the shared equal-area map.
target_include_directories(cbdpt_fuzz_scene PUBLIC ${CMAKE_SOURCE_DIR}/src ${CMAKE_SOURCE_DIR}/kernels)
target_include_directories(cbdpt_fuzz_scene SYSTEM PUBLIC ${STB_INCLUDE_DIR} ${QOI_INCLUDE_DIR})
target_link_libraries(cbdpt_fuzz_scene PUBLIC fmt::fmt ZLIB::ZLIB OpenEXR::OpenEXR PNG::PNG
                      ${STB_LIBRARY})
# The library gets fuzzer-no-link: libFuzzer's main() is linked into each target only.
target_compile_options(cbdpt_fuzz_scene PUBLIC -fsanitize=fuzzer-no-link,address,undefined
                       -fno-sanitize-recover=all -fno-omit-frame-pointer -g)
foreach(target fuzz_scene fuzz_ply)
  add_executable(${target} ${CMAKE_CURRENT_LIST_DIR}/${target}.cpp)
  target_link_libraries(${target} PRIVATE cbdpt_fuzz_scene)
  target_compile_options(${target} PRIVATE ${CBDPT_FUZZ_FLAGS})
  target_link_options(${target} PRIVATE ${CBDPT_FUZZ_FLAGS})
endforeach()
