# omni4_dep(NAME pkg-config-name header library): an imported target PkgConfig::NAME.
# Native builds ask pkg-config; cross builds search the unpacked Debian sysroot (pkg-config
# files there pull in the whole -dev dependency chain, which the sysroot does not carry).
function(omni4_dep name pcname header lib)
  if(TARGET PkgConfig::${name})
    return()
  endif()
  if(NOT CMAKE_CROSSCOMPILING)
    pkg_check_modules(${name} REQUIRED IMPORTED_TARGET GLOBAL ${pcname})
    return()
  endif()
  find_path(${name}_INCLUDE_DIR ${header} REQUIRED)
  find_library(${name}_LIBRARY ${lib} REQUIRED)
  add_library(PkgConfig::${name} UNKNOWN IMPORTED GLOBAL)
  set_target_properties(PkgConfig::${name} PROPERTIES IMPORTED_LOCATION ${${name}_LIBRARY}
    INTERFACE_INCLUDE_DIRECTORIES ${${name}_INCLUDE_DIR})
  # liblcm needs glib at link time: let the linker find DT_NEEDED libraries in the sysroot.
  get_filename_component(libdir ${${name}_LIBRARY} DIRECTORY)
  target_link_options(PkgConfig::${name} INTERFACE "-Wl,-rpath-link,${libdir}")
endfunction()
