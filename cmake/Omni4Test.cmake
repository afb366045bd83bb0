# Test registration helpers.
#
# OMNI4_TEST_TIME_SCALE: integer multiplier of every test's TIMEOUT (and of the loop-timing
# bounds of the tests that measure latency, through the environment variable of the same name).
# 1 for release builds; the sanitizer presets set it (CMakePresets.json), cross builds under
# qemu-user multiply by 5 on top.
set(OMNI4_TEST_TIME_SCALE 1 CACHE STRING "multiplier of test TIMEOUTs and timing bounds")

# OMNI4_SANITIZER: "address" or "thread" in the sanitizer presets (CMakePresets.json), else "".
set(OMNI4_SANITIZER "" CACHE STRING "sanitizer of this build: address, thread or empty")

# omni4_test_timeout(NAME SECONDS [ASAN S] [TSAN S] [UNSCALED]): the test's TIMEOUT, and
# OMNI4_TEST_TIME_SCALE in its environment. SECONDS is ~2-2.5x the test's time on a 2-core
# machine, at least 10 s (a sub-second test on a loaded machine). Under a sanitizer:
#   ASAN / TSAN S   ~2-2.5x the time measured under that sanitizer;
#   UNSCALED        the test's time does not grow there (paced by the clock, or Python-bound):
#                   SECONDS as it is;
#   otherwise       10 s for a test at the 10 s floor (all of these take < 1.5 s under ASan and
#                   TSan), SECONDS x OMNI4_TEST_TIME_SCALE for anything else.
# Cross builds run under qemu-user: x 5 on top.
# Then x OMNI4_TEST_LOAD_MARGIN (4) for every test: a TIMEOUT only ends a test that hangs, and
# the figures above are from a quiet machine; beside two CPU hogs and a parallel build (a
# loaded 2-core machine) a CPU-bound test runs up to ~3x slower, and must still pass. A test
# that passes never waits its TIMEOUT out, so the margin costs nothing but the time to notice a
# hang.
set(OMNI4_TEST_LOAD_MARGIN 4 CACHE STRING "multiplier of every test TIMEOUT for a loaded machine")
function(omni4_test_timeout name seconds)
  cmake_parse_arguments(T "UNSCALED" "ASAN;TSAN" "" ${ARGN})
  if(OMNI4_SANITIZER STREQUAL "address" AND T_ASAN)
    set(t ${T_ASAN})
  elseif(OMNI4_SANITIZER STREQUAL "thread" AND T_TSAN)
    set(t ${T_TSAN})
  elseif(T_UNSCALED OR (OMNI4_SANITIZER AND seconds LESS_EQUAL 10))
    set(t ${seconds})
  else()
    math(EXPR t "${seconds} * ${OMNI4_TEST_TIME_SCALE}")
  endif()
  if(CMAKE_CROSSCOMPILING)
    math(EXPR t "${t} * 5")
  endif()
  math(EXPR t "${t} * ${OMNI4_TEST_LOAD_MARGIN}")
  set_property(TEST ${name} PROPERTY TIMEOUT ${t})
  set_property(TEST ${name} APPEND PROPERTY ENVIRONMENT
    "OMNI4_TEST_TIME_SCALE=${OMNI4_TEST_TIME_SCALE}")
endfunction()

# omni4_add_test(NAME SOURCES src... LIBS lib... LABELS label... TIMEOUT s [WRAP sym...]
#                [ARGS arg...])
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
    message(FATAL_ERROR "omni4_add_test(${name}): TIMEOUT is required")
  endif()
  if(CMAKE_CROSSCOMPILING)
    list(APPEND T_LABELS qemu)
  endif()
  set_tests_properties(${name} PROPERTIES LABELS "${T_LABELS}"
    ENVIRONMENT "OMNI4_SOURCE_DIR=${PROJECT_SOURCE_DIR};OMNI4_BINARY_DIR=${PROJECT_BINARY_DIR}")
  omni4_test_timeout(${name} ${T_TIMEOUT})
endfunction()

# What the controller core with the model may take from outside on any target: mem*, libm and
# the ARM EABI helpers (soft double, division). Never an OS call, LCM, malloc, stdio or
# libatomic. The Linux targets add their own (tests/CMakeLists.txt).
set(OMNI4_CORE_ALLOWED_SYMBOLS
  "mem(set|cpy|cmp|move)|((ll|l)?round|sqrt|exp|log|sin|cos|atan2|fmod|floor|ceil|fmax|fmin)f?|__aeabi_[a-z0-9]+")

# omni4_add_undefined_check(NAME WHAT OBJECTS objs... [ALLOWED regex]): a test that links the
# objects into one relocatable object and fails on any external symbol not matching ALLOWED
# (anchored; none at all without it): cmake/check_undefined_allowed.cmake.
function(omni4_add_undefined_check name what)
  cmake_parse_arguments(T "" "ALLOWED" "OBJECTS" ${ARGN})
  set(allowed "")
  if(T_ALLOWED)
    set(allowed "-DALLOWED=${T_ALLOWED}")
  endif()
  add_test(NAME ${name}
    COMMAND ${CMAKE_COMMAND} -DCC=${CMAKE_C_COMPILER} -DNM=${CMAKE_NM}
            -DOUT=${CMAKE_CURRENT_BINARY_DIR} -DNAME=${what} "-DOBJECTS=${T_OBJECTS}" ${allowed}
            -P ${PROJECT_SOURCE_DIR}/cmake/check_undefined_allowed.cmake)
endfunction()
