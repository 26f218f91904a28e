# The host's instances of the shared kernel code (src/kernel_host/kernel_instance.h explains the
# mechanism): each source listed with a (real type, channel count) is compiled once for it, with
# -DCB_REAL and -DCB_CHANNELS, into an object library linked into cbdpt_core. Sources named
# *_instance.cpp are compiled only here.
function(cbdpt_kernel_instance real channels)
  set(target cbdpt_kernels_${real}_${channels})
  add_library(${target} OBJECT ${ARGN})
  target_compile_definitions(${target} PRIVATE CB_REAL=${real} CB_CHANNELS=${channels})
  target_include_directories(${target} PRIVATE ${CMAKE_SOURCE_DIR}/src ${CMAKE_SOURCE_DIR}/kernels)
  target_sources(cbdpt_core PRIVATE $<TARGET_OBJECTS:${target}>)
endfunction()

set(CBDPT_LIGHT_PASS ${CMAKE_SOURCE_DIR}/src/integrators/cbdpt_light_instance.cpp)
set(CBDPT_FLOAT64_CHECK ${CMAKE_SOURCE_DIR}/src/float64/host_kernels_instance.cpp)
# RGB: CBDPT's light pass and the float64 check's float control (the global `cbk`).
cbdpt_kernel_instance(float 3 ${CBDPT_LIGHT_PASS} ${CBDPT_FLOAT64_CHECK})
# Spectral scenes: CBDPT's light pass with the kernels' 16 channels.
cbdpt_kernel_instance(float 16 ${CBDPT_LIGHT_PASS})
# The float64 check: the kernel code and CBDPT's light pass in double.
cbdpt_kernel_instance(double 3 ${CBDPT_LIGHT_PASS} ${CBDPT_FLOAT64_CHECK})
