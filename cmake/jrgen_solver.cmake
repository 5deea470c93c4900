# add_jr_solver(TARGET <name> URDF <file> [CUTS <file>] [NAMESPACE <ns>] [OPTIONS <jrgen options>...])
#
# Generates <name>.cpp and <name>.hpp with jrgen at build time and compiles
# them into the static library <name>, linked with the jrgen runtime.  The
# generated header is on the target's include path (#include "<name>.hpp").
# The solver is regenerated when the URDF, the cuts file or jrgen changes.
# Relative paths are taken from the calling CMakeLists.txt's folder.
#
# Needs JRGEN_EXECUTABLE (the jrgen program, a path or generator expression)
# and the target jrgen::runtime, both set by find_package(jrgen) or by
# jrgen's own CMakeLists.txt.
function(add_jr_solver)
  cmake_parse_arguments(ARG "" "TARGET;URDF;CUTS;NAMESPACE" "OPTIONS" ${ARGN})
  if(NOT ARG_TARGET OR NOT ARG_URDF)
    message(FATAL_ERROR "add_jr_solver: TARGET and URDF are required")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "add_jr_solver: unknown arguments: ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  get_filename_component(urdf "${ARG_URDF}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/jrgen/${ARG_TARGET}")
  set(out_cpp "${out_dir}/${ARG_TARGET}.cpp")
  set(out_hpp "${out_dir}/${ARG_TARGET}.hpp")
  set(cmd "${JRGEN_EXECUTABLE}" "${urdf}" -o "${out_cpp}")
  set(deps "${urdf}")
  if(ARG_CUTS)
    get_filename_component(cuts "${ARG_CUTS}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    list(APPEND cmd --cuts "${cuts}")
    list(APPEND deps "${cuts}")
  endif()
  if(ARG_NAMESPACE)
    list(APPEND cmd --namespace "${ARG_NAMESPACE}")
  endif()
  list(APPEND cmd ${ARG_OPTIONS})
  if(TARGET jrgen)
    list(APPEND deps jrgen)          # building jrgen itself: rerun when it changes
  elseif(TARGET jrgen::jrgen)
    list(APPEND deps jrgen::jrgen)   # installed package
  endif()
  file(MAKE_DIRECTORY "${out_dir}")
  add_custom_command(
    OUTPUT "${out_cpp}" "${out_hpp}"
    COMMAND ${cmd}
    DEPENDS ${deps}
    COMMENT "jrgen: generating ${ARG_TARGET} from ${ARG_URDF}"
    VERBATIM)
  add_library(${ARG_TARGET} STATIC "${out_cpp}" "${out_hpp}")
  target_include_directories(${ARG_TARGET} PUBLIC "${out_dir}")
  target_link_libraries(${ARG_TARGET} PUBLIC jrgen::runtime)
  target_compile_features(${ARG_TARGET} PUBLIC cxx_std_17)
  set_target_properties(${ARG_TARGET} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()
