# cmake -DCC=cc -DNM=nm -DOUT=dir -DOBJECTS="a.o;b.o" -P check_no_undefined.cmake
# Links the objects into one relocatable object and fails if it references any external
# symbol (libc, libm, libgcc float helpers, malloc): the fixed-point path must stand alone.
set(combined ${OUT}/model_fixed_combined.o)
execute_process(COMMAND ${CC} -nostdlib -r -o ${combined} ${OBJECTS} RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "partial link of ${OBJECTS} failed")
endif()
execute_process(COMMAND ${NM} -u ${combined} OUTPUT_VARIABLE undef RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "nm failed on ${combined}")
endif()
string(STRIP "${undef}" undef)
if(undef)
  message(FATAL_ERROR "the fixed-point path needs external symbols:\n${undef}")
endif()
message(STATUS "fixed-point path (${OBJECTS}): no external symbols")
