# Writes OUTPUT, a header that defines CBDPT_GIT_REVISION: the commit of SOURCE_DIR ("unknown"
# outside git), with "-dirty" when the code the binary is built from (CMakeLists.txt, src/,
# kernels/) differs from it; changes elsewhere (unit logs, docs) do not count. Run at every
# build; the file is rewritten only when the text changed, so that only then main.cpp is
# compiled again.
#   cmake -DSOURCE_DIR=... -DOUTPUT=... -P scripts/git_revision.cmake
execute_process(COMMAND git -C ${SOURCE_DIR} describe --always --abbrev=12
                OUTPUT_VARIABLE revision OUTPUT_STRIP_TRAILING_WHITESPACE
                ERROR_QUIET RESULT_VARIABLE result)
if(NOT result EQUAL 0 OR revision STREQUAL "")
  set(revision "unknown")
else()
  execute_process(COMMAND git -C ${SOURCE_DIR} diff --quiet HEAD -- CMakeLists.txt src kernels
                  RESULT_VARIABLE changed ERROR_QUIET)
  if(NOT changed EQUAL 0)
    string(APPEND revision "-dirty")
  endif()
endif()
set(content "#define CBDPT_GIT_REVISION \"${revision}\"\n")
set(previous "")
if(EXISTS ${OUTPUT})
  file(READ ${OUTPUT} previous)
endif()
if(NOT previous STREQUAL content)
  file(WRITE ${OUTPUT} "${content}")
endif()
