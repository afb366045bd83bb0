# Writes omni4/version.h with OMNI4_VERSION: the project version and `git describe` of the
# source tree (with -dirty for uncommitted changes), or the project version alone outside a
# git checkout. Run at every build (cmake -P); the header changes only when the version does.
#   -DSRC=source dir -DOUT=header path -DPROJECT_VERSION=x.y.z
execute_process(COMMAND git describe --always --dirty --tags
                WORKING_DIRECTORY "${SRC}" OUTPUT_VARIABLE described
                OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE rc)
if(rc EQUAL 0 AND described)
  set(version "${PROJECT_VERSION} (${described})")
else()
  set(version "${PROJECT_VERSION}")
endif()
set(text "/* Generated at build time by cmake/Omni4VersionHeader.cmake. */\n#define OMNI4_VERSION \"${version}\"\n")
if(EXISTS "${OUT}")
  file(READ "${OUT}" old)
endif()
if(NOT old STREQUAL text)
  file(WRITE "${OUT}" "${text}")
endif()
