# omni4_add_test(NAME SOURCES src... LIBS lib... LABELS label... [WRAP sym...] [ARGS arg...])
# Registers one cmocka test executable with CTest. It runs through
# CMAKE_CROSSCOMPILING_EMULATOR when cross compiling, so the same list runs under qemu-user.
function(omni4_add_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS;WRAP;ARGS" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE ${T_LIBS} omni4_warnings)
  target_compile_definitions(${name} PRIVATE _DEFAULT_SOURCE)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests/common)
  foreach(sym IN LISTS T_WRAP)
    target_link_options(${name} PRIVATE "-Wl,--wrap=${sym}")
  endforeach()
  add_test(NAME ${name} COMMAND ${CMAKE_CROSSCOMPILING_EMULATOR} $<TARGET_FILE:${name}> ${T_ARGS})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 120)
  endif()
  set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT}
    ENVIRONMENT "OMNI4_SOURCE_DIR=${PROJECT_SOURCE_DIR};OMNI4_BINARY_DIR=${PROJECT_BINARY_DIR}")
endfunction()
