# SPDX-License-Identifier: Apache-2.0
# rtm_component_module(<program> [NO_INSTALL] [DESTINATION <build folder>])
#
# The program's component as a module for rtm-container (host/module.h): the same sources,
# definitions and libraries, built with RTM_BUILD_MODULE (so its RTM_COMPONENT(...) is the
# module's entry instead of main()), as lib/rtm/modules/<program>.so in the build tree and the
# install. Call it in the program's folder after the program's target_link_libraries. The
# static libraries it links are built as position-independent code. A test's component:
# NO_INSTALL, and DESTINATION for its own folder in the build tree.
function(rtm_component_module program)
  cmake_parse_arguments(ARG "NO_INSTALL" "DESTINATION" "" ${ARGN})
  if(NOT ARG_DESTINATION)
    set(ARG_DESTINATION ${CMAKE_BINARY_DIR}/lib/rtm/modules)
  endif()
  get_target_property(sources ${program} SOURCES)
  get_target_property(libs ${program} LINK_LIBRARIES)
  get_target_property(definitions ${program} COMPILE_DEFINITIONS)
  set(module ${program}-module)
  add_library(${module} MODULE ${sources})
  rtm_warnings(${module})
  target_link_libraries(${module} PRIVATE ${libs})
  if(definitions)
    target_compile_definitions(${module} PRIVATE ${definitions})
  endif()
  target_compile_definitions(${module} PRIVATE RTM_BUILD_MODULE)
  set_target_properties(${module} PROPERTIES OUTPUT_NAME ${program} PREFIX ""
                        LIBRARY_OUTPUT_DIRECTORY ${ARG_DESTINATION}
                        INSTALL_RPATH "$ORIGIN/../..")
  _rtm_position_independent(${libs})
  if(NOT ARG_NO_INSTALL)
    install(TARGETS ${module} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/rtm/modules COMPONENT runtime)
  endif()
endfunction()

# Every static library of this project among libs, and those they link, as PIC.
function(_rtm_position_independent)
  foreach(lib ${ARGN})
    if(lib MATCHES "^\\$<" OR NOT TARGET ${lib})
      continue()
    endif()
    get_target_property(imported ${lib} IMPORTED)
    get_target_property(aliased ${lib} ALIASED_TARGET)
    if(aliased)
      set(lib ${aliased})
    endif()
    get_target_property(type ${lib} TYPE)
    if(imported OR NOT type STREQUAL "STATIC_LIBRARY")
      continue()
    endif()
    get_target_property(done ${lib} POSITION_INDEPENDENT_CODE)
    if(done)
      continue()
    endif()
    set_target_properties(${lib} PROPERTIES POSITION_INDEPENDENT_CODE ON)
    get_target_property(more ${lib} LINK_LIBRARIES)
    if(more)
      _rtm_position_independent(${more})
    endif()
  endforeach()
endfunction()
