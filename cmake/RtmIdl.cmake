# rtm_idl_library(<target> IDL <files...> [SHORTCUT] [INCLUDE_DIRS <dirs>] [DEPENDS <idl targets>])
#
# Runs omniidl on each IDL file and builds the stubs and skeletons into a static library.
# SHORTCUT generates omniORB's local-call shortcut stubs (-Wbshortcut): together with the
# POA policy LOCAL_CALLS_SHORTCUT a collocated call then costs about a virtual call.
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
  target_include_directories(${target} SYSTEM PUBLIC ${out_dir})
  target_link_libraries(${target} PUBLIC rtm_omniorb ${ARG_DEPENDS} Threads::Threads)
  target_compile_options(${target} PRIVATE -w)
endfunction()
