# SPDX-License-Identifier: Apache-2.0
# rtm_add_component(<program> SOURCES <src...> [LIBS <lib...>] [DEFINITIONS <def...>]
#                   [BIN_DIR <folder>] [NO_INSTALL])
#
# A component's program and its module for rtm-container (host/module.h), from one compile: the
# sources (whose component ends in RTM_COMPONENT(...)) are built once as position-independent
# code, then linked as <BIN_DIR>/<program> and as <BIN_DIR>/../lib/rtm/modules/<program>.so
# (BIN_DIR: the build folder's bin/), and installed as bin/<program> and
# lib/rtm/modules/<program>.so unless NO_INSTALL. The static libraries of the project it links
# are built position-independent too. The targets: <program>, <program>-module.
include_guard(GLOBAL)
include(GNUInstallDirs)

function(rtm_add_component program)
  cmake_parse_arguments(ARG "NO_INSTALL" "BIN_DIR" "SOURCES;LIBS;DEFINITIONS" ${ARGN})
  if(NOT ARG_SOURCES)
    message(FATAL_ERROR "rtm_add_component(${program}): no SOURCES given")
  endif()
  if(NOT ARG_BIN_DIR)
    set(ARG_BIN_DIR ${CMAKE_BINARY_DIR}/bin)
  endif()
  get_filename_component(parent ${ARG_BIN_DIR} DIRECTORY)
  set(objects ${program}-objects)
  set(module ${program}-module)
  add_library(${objects} OBJECT ${ARG_SOURCES})
  set_target_properties(${objects} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_link_libraries(${objects} PUBLIC ${ARG_LIBS})
  if(ARG_DEFINITIONS)
    target_compile_definitions(${objects} PRIVATE ${ARG_DEFINITIONS})
  endif()
  if(COMMAND rtm_warnings)
    rtm_warnings(${objects})
  endif()
  add_executable(${program} $<TARGET_OBJECTS:${objects}>)
  target_link_libraries(${program} PRIVATE ${ARG_LIBS})
  set_target_properties(${program} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${ARG_BIN_DIR})
  add_library(${module} MODULE $<TARGET_OBJECTS:${objects}>)
  target_link_libraries(${module} PRIVATE ${ARG_LIBS})
  set_target_properties(${module} PROPERTIES OUTPUT_NAME ${program} PREFIX ""
                        LIBRARY_OUTPUT_DIRECTORY ${parent}/lib/rtm/modules
                        INSTALL_RPATH "$ORIGIN/../..")
  _rtm_position_independent(${ARG_LIBS})
  if(NOT ARG_NO_INSTALL)
    install(TARGETS ${program} RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
    install(TARGETS ${module} LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}/rtm/modules COMPONENT runtime)
  endif()
endfunction()

# Every static library of this project among the libraries, and those they link, as PIC.
function(_rtm_position_independent)
  foreach(lib ${ARGN})
    if(lib MATCHES "^\\$<" OR NOT TARGET ${lib})
      continue()
    endif()
    get_target_property(aliased ${lib} ALIASED_TARGET)
    if(aliased)
      set(lib ${aliased})
    endif()
    get_target_property(imported ${lib} IMPORTED)
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
