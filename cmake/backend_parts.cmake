# backend_parts.cmake - what a C macro cannot take from a row of backends.def (a header to
# include, a key list to include, a struct member per backend with settings), written at
# configure time into OUT_DIR/omni4/: backend_settings.h (OMNI4_BACKEND_SETTINGS(X):
# X(member, settings) per backend with settings, in the rows' order, and their headers),
# backend_states.h (the headers of the backends' states) and backend_keys.inc (each backend's
# key list under OMNI4_BACKEND_MEMBER). A row this cannot read stops the configure step. The
# rows are those of the DEF files after OUT_DIR, in order (a test adds its own rows after
# backends.def's); a backend's settings header <settings>.h and key list lie beside the
# header of its state.
function(omni4_backend_parts OUT_DIR)
  set(rows "")
  foreach(def IN LISTS ARGN)
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${def})
    file(STRINGS ${def} more REGEX "^OMNI4_BACKEND\\(")
    list(APPEND rows ${more})
  endforeach()
  set(q "\"([^\"]*)\"")
  set(id "([A-Za-z0-9_]+)")
  set(row_re "^OMNI4_BACKEND\\(${id}, ${id}, ${q}, ${q}, ${id}, ${id}, ${id}, ${q}, ${id}, \".*\"\\)$")
  set(any "")
  set(linux "")
  set(settings "")
  set(headers "")
  set(keys "")
  foreach(row IN LISTS rows)
    if(NOT row MATCHES "${row_re}")
      message(FATAL_ERROR "${ARGN}: a row backend_parts.cmake cannot read: ${row}")
    endif()
    set(keyfile ${CMAKE_MATCH_4})
    set(member ${CMAKE_MATCH_5})
    set(type ${CMAKE_MATCH_6})
    set(os ${CMAKE_MATCH_9})
    set(header ${CMAKE_MATCH_8})
    set(include "#include \"${header}\"\n")
    string(FIND "${any}${linux}" "${include}" seen)
    if(NOT seen EQUAL -1)
    elseif(os STREQUAL "LINUX")
      string(APPEND linux "${include}")
    else()
      string(APPEND any "${include}")
    endif()
    if(NOT type STREQUAL "none")
      get_filename_component(dir ${header} DIRECTORY)
      string(APPEND headers "#include \"${dir}/${type}.h\"\n")
      string(APPEND settings " X(${member}, ${type})")
      string(APPEND keys "#define OMNI4_BACKEND_MEMBER ${member}\n"
        "#include \"${dir}/${keyfile}\"\n#undef OMNI4_BACKEND_MEMBER\n")
    endif()
  endforeach()
  set(from "generated from backends.def by cmake/backend_parts.cmake")
  file(CONFIGURE OUTPUT ${OUT_DIR}/omni4/drivers/backend_settings.h @ONLY CONTENT
"/* backend_settings.h - ${from}:
 * X(member, settings) for each backend with settings, and their headers. */
#ifndef OMNI4_BACKEND_SETTINGS_H
#define OMNI4_BACKEND_SETTINGS_H

#include \"omni4/drivers/backends.h\"
${headers}
#define OMNI4_BACKEND_SETTINGS(X)${settings}

#endif /* OMNI4_BACKEND_SETTINGS_H */
")
  file(CONFIGURE OUTPUT ${OUT_DIR}/omni4/drivers/backend_states.h @ONLY CONTENT
"/* backend_states.h - ${from}:
 * the headers of the backends' states (the Linux ones on Linux only). */
#ifndef OMNI4_BACKEND_STATES_H
#define OMNI4_BACKEND_STATES_H

#include \"omni4/drivers/backend_settings.h\"
${any}#ifdef OMNI4_ROBOT_LINUX
${linux}#endif

#endif /* OMNI4_BACKEND_STATES_H */
")
  file(CONFIGURE OUTPUT ${OUT_DIR}/omni4/drivers/backend_keys.inc @ONLY CONTENT
"/* backend_keys.inc - ${from}:
 * each backend's key list, OMNI4_BACKEND_MEMBER its member; the includer defines OMNI4_KEY. */
${keys}")
endfunction()
