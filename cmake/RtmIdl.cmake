# SPDX-License-Identifier: Apache-2.0
# IDL stubs, in this tree and for projects built on the installed package (RTMConfig.cmake
# includes this file).
#
# rtm_idl_library(<target> IDL <files...> [SHORTCUT] [INCLUDE_DIRS <dirs>] [DEPENDS <targets>])
#
# Runs omniidl on each IDL file and builds the stubs and skeletons into a static library.
# SHORTCUT generates omniORB's local-call shortcut stubs (-Wbshortcut): together with the
# POA policy LOCAL_CALLS_SHORTCUT a collocated call then costs about a virtual call.
#
# rtm_add_idl(<target> FILES <idl files...> [INCLUDE_DIRS <dirs>])
#
# A project's own data types: stubs (with the shortcut) of its IDL files in a static library
# <target> that links RTM's own (RTM::idl). The files may #include "RTM.idl" (Time,
# TimedFloat6) and "RTMData.idl". Link <target> to the component that uses the types:
# rtm::InPort<My::TimedPose> and rtm::OutPort<My::TimedPose> then work, and rtm get/put/watch
# read the type from the port itself.
find_program(OMNIIDL_EXECUTABLE omniidl REQUIRED)

function(rtm_idl_library target)
  cmake_parse_arguments(ARG "SHORTCUT" "" "IDL;INCLUDE_DIRS;DEPENDS" ${ARGN})
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target})
  file(MAKE_DIRECTORY ${out_dir})
  set(backend_flags -bcxx -Wba -Wbh=.hh -Wbs=SK.cc -Wbd=DynSK.cc -Wbkeep_inc_path)
  if(ARG_SHORTCUT)
    list(APPEND backend_flags -Wbshortcut)
  endif()
  set(include_flags)
  foreach(dir ${ARG_INCLUDE_DIRS})
    list(APPEND include_flags -I${dir})
  endforeach()
  set(sources)
  foreach(idl ${ARG_IDL})
    get_filename_component(abs ${idl} ABSOLUTE)
    get_filename_component(stem ${idl} NAME_WE)
    set(generated ${out_dir}/${stem}.hh ${out_dir}/${stem}SK.cc ${out_dir}/${stem}DynSK.cc)
    add_custom_command(
      OUTPUT ${generated}
      COMMAND ${OMNIIDL_EXECUTABLE} ${backend_flags} ${include_flags} -C ${out_dir} ${abs}
      DEPENDS ${abs}
      COMMENT "omniidl ${stem}.idl -> ${target}"
      VERBATIM)
    list(APPEND sources ${out_dir}/${stem}SK.cc ${out_dir}/${stem}DynSK.cc)
  endforeach()
  add_library(${target} STATIC ${sources})
  set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  target_include_directories(${target} SYSTEM PUBLIC $<BUILD_INTERFACE:${out_dir}>)
  # In this tree the ORB is rtm_omniorb; in a project on the package, RTM::omniorb.
  if(TARGET rtm_omniorb)
    target_link_libraries(${target} PUBLIC rtm_omniorb)
  else()
    target_link_libraries(${target} PUBLIC RTM::omniorb)
  endif()
  target_link_libraries(${target} PUBLIC ${ARG_DEPENDS})
  target_compile_options(${target} PRIVATE -w)
endfunction()

function(rtm_add_idl target)
  cmake_parse_arguments(ARG "" "" "FILES;INCLUDE_DIRS" ${ARGN})
  if(NOT ARG_FILES)
    message(FATAL_ERROR "rtm_add_idl(${target}): no FILES given")
  endif()
  if(NOT RTM_IDL_DIR)
    message(FATAL_ERROR "rtm_add_idl(${target}): RTM_IDL_DIR is not set (find_package(RTM) sets it)")
  endif()
  set(dirs)
  foreach(idl ${ARG_FILES})
    get_filename_component(abs ${idl} ABSOLUTE)
    get_filename_component(dir ${abs} DIRECTORY)
    list(APPEND dirs ${dir})
  endforeach()
  list(REMOVE_DUPLICATES dirs)
  rtm_idl_library(${target} SHORTCUT IDL ${ARG_FILES} INCLUDE_DIRS ${dirs} ${ARG_INCLUDE_DIRS} ${RTM_IDL_DIR}
                  DEPENDS RTM::idl)
endfunction()
