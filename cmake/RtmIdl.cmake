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
# rtm_add_idl(<target> FILES <idl files...> [TYPES <Module::Type...>] [INCLUDE_DIRS <dirs>] [EXPORT])
#
# A project's own data types: stubs (with the shortcut) of its IDL files in a static library
# <target> that links RTM's own (RTM::idl), also known as <target>::<target>. The files may
# #include "RTM.idl" (Time, TimedFloat6) and "RTMData.idl". rtm get/put/watch read the types
# from the ports themselves.
#
# TYPES names the port types among them. A header <target>.h is written that includes the
# stub headers and makes each a port type (RTM_DATA_TYPE): a component includes it and uses
# rtm::InPort<My::TimedPose> and rtm::OutPort<My::TimedPose>.
#
# EXPORT makes <target> a package of its own for other projects: `cmake --install` puts the
# library, its headers (include/<target>/), its IDL files (share/<target>/idl/) and
# <target>Config.cmake (lib/cmake/<target>/), and their find_package(<target>) gives the
# target <target>::<target> and <target>_IDL_DIR, for IDL of theirs that includes these files.
find_program(OMNIIDL_EXECUTABLE omniidl REQUIRED)

function(rtm_idl_library target)
  cmake_parse_arguments(ARG "SHORTCUT" "TYPE" "IDL;INCLUDE_DIRS;DEPENDS" ${ARGN})
  if(NOT ARG_TYPE)
    set(ARG_TYPE STATIC)
  endif()
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
  add_library(${target} ${ARG_TYPE} ${sources})
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
  cmake_parse_arguments(ARG "EXPORT" "" "FILES;INCLUDE_DIRS;TYPES" ${ARGN})
  if(NOT ARG_FILES)
    message(FATAL_ERROR "rtm_add_idl(${target}): no FILES given")
  endif()
  if(NOT RTM_IDL_DIR)
    message(FATAL_ERROR "rtm_add_idl(${target}): RTM_IDL_DIR is not set (find_package(RTM) sets it)")
  endif()
  set(dirs)
  set(stems)
  foreach(idl ${ARG_FILES})
    get_filename_component(abs ${idl} ABSOLUTE)
    get_filename_component(dir ${abs} DIRECTORY)
    get_filename_component(stem ${idl} NAME_WE)
    list(APPEND dirs ${dir})
    list(APPEND stems ${stem})
  endforeach()
  list(REMOVE_DUPLICATES dirs)
  rtm_idl_library(${target} SHORTCUT IDL ${ARG_FILES} INCLUDE_DIRS ${dirs} ${ARG_INCLUDE_DIRS} ${RTM_IDL_DIR}
                  DEPENDS RTM::idl)
  add_library(${target}::${target} ALIAS ${target})
  set(out_dir ${CMAKE_CURRENT_BINARY_DIR}/${target})
  set(headers)
  foreach(stem ${stems})
    list(APPEND headers ${out_dir}/${stem}.hh)
  endforeach()
  if(ARG_TYPES)
    set(text "// ${target}.h, written by rtm_add_idl: the port types of ${target}'s IDL.\n#pragma once\n\n")
    string(APPEND text "#include \"rtm/data.h\"\n\n")
    foreach(stem ${stems})
      string(APPEND text "#include <${stem}.hh>\n")
    endforeach()
    string(APPEND text "\n")
    foreach(type ${ARG_TYPES})
      if(NOT type MATCHES "^([A-Za-z_][A-Za-z0-9_]*(::[A-Za-z_][A-Za-z0-9_]*)*)::([A-Za-z_][A-Za-z0-9_]*)$")
        message(FATAL_ERROR "rtm_add_idl(${target}): TYPES '${type}' is no Module::Type (e.g. My::TimedPose)")
      endif()
      string(APPEND text "RTM_DATA_TYPE(${CMAKE_MATCH_1}, ${CMAKE_MATCH_3});\n")
    endforeach()
    file(GENERATE OUTPUT ${out_dir}/${target}.h CONTENT "${text}")
    list(APPEND headers ${out_dir}/${target}.h)
    target_link_libraries(${target} INTERFACE RTM::core)
  endif()
  if(ARG_EXPORT)
    _rtm_export_idl(${target} "${ARG_FILES}" "${headers}")
  endif()
endfunction()

# The install rules and the package files of rtm_add_idl(... EXPORT).
function(_rtm_export_idl target files headers)
  include(GNUInstallDirs)
  include(CMakePackageConfigHelpers)
  target_include_directories(${target} SYSTEM PUBLIC $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}/${target}>)
  install(TARGETS ${target} EXPORT ${target}Targets ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
  install(FILES ${headers} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/${target})
  install(FILES ${files} DESTINATION ${CMAKE_INSTALL_DATADIR}/${target}/idl)
  set(package_dir ${CMAKE_INSTALL_LIBDIR}/cmake/${target})
  install(EXPORT ${target}Targets NAMESPACE ${target}:: DESTINATION ${package_dir})
  set(config_in ${CMAKE_CURRENT_BINARY_DIR}/${target}Config.cmake.in)
  file(WRITE ${config_in}
       "# ${target}: data types of RTM components (made by rtm_add_idl(... EXPORT)).\n"
       "@PACKAGE_INIT@\n"
       "# Before find_dependency: other packages' configs set PACKAGE_PREFIX_DIR again.\n"
       "set_and_check(${target}_IDL_DIR \"@PACKAGE_${target}_IDL_INSTALL_DIR@\")\n"
       "include(CMakeFindDependencyMacro)\n"
       "find_dependency(RTM COMPONENTS core idl omniorb)\n"
       "include(\${CMAKE_CURRENT_LIST_DIR}/${target}Targets.cmake)\n")
  set(${target}_IDL_INSTALL_DIR ${CMAKE_INSTALL_DATADIR}/${target}/idl)
  configure_package_config_file(${config_in} ${CMAKE_CURRENT_BINARY_DIR}/${target}Config.cmake
                                INSTALL_DESTINATION ${package_dir} PATH_VARS ${target}_IDL_INSTALL_DIR)
  set(package_files ${CMAKE_CURRENT_BINARY_DIR}/${target}Config.cmake)
  if(PROJECT_VERSION)
    write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/${target}ConfigVersion.cmake
                                     VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
    list(APPEND package_files ${CMAKE_CURRENT_BINARY_DIR}/${target}ConfigVersion.cmake)
  endif()
  install(FILES ${package_files} DESTINATION ${package_dir})
endfunction()
