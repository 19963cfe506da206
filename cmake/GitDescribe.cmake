# Writes OUT (a header defining CTCAL_GIT_DESCRIBE) from `git describe` of SRC; run as a build step
# (cmake -P) so the version follows the tree, and rewrites OUT only when it changed (no rebuild
# of its users otherwise). "unknown" outside a git checkout.
execute_process(COMMAND git describe --always --dirty --tags
  WORKING_DIRECTORY ${SRC} OUTPUT_VARIABLE describe RESULT_VARIABLE rc
  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(NOT rc EQUAL 0 OR describe STREQUAL "")
  set(describe "unknown")
endif()
set(content "#define CTCAL_GIT_DESCRIBE \"${describe}\"\n")
set(old "")
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT old STREQUAL content)
  file(WRITE ${OUT} "${content}")
endif()
