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
# jrgen's own CMakeLists.txt before including this file.  The program is
# remembered in a global property, so add_jr_solver() also works from a
# project that pulled jrgen in with add_subdirectory() (where jrgen's
# directory variables are not visible); a JRGEN_EXECUTABLE variable visible
# at the call still takes precedence.
if(NOT JRGEN_EXECUTABLE)
  message(FATAL_ERROR "jrgen_solver.cmake: set JRGEN_EXECUTABLE before including this file")
endif()
set_property(GLOBAL PROPERTY JRGEN_EXECUTABLE "${JRGEN_EXECUTABLE}")

function(add_jr_solver)
  cmake_parse_arguments(ARG "" "TARGET;URDF;CUTS;NAMESPACE" "OPTIONS" ${ARGN})
  if(NOT ARG_TARGET OR NOT ARG_URDF)
    message(FATAL_ERROR "add_jr_solver: TARGET and URDF are required")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "add_jr_solver: unknown arguments: ${ARG_UNPARSED_ARGUMENTS}")
  endif()
  list(REMOVE_ITEM ARG_KEYWORDS_MISSING_VALUES OPTIONS)  # an empty OPTIONS list is fine
  if(ARG_KEYWORDS_MISSING_VALUES)
    message(FATAL_ERROR "add_jr_solver: no value given for ${ARG_KEYWORDS_MISSING_VALUES}")
  endif()
  set(exe "${JRGEN_EXECUTABLE}")
  if(NOT exe)
    get_property(exe GLOBAL PROPERTY JRGEN_EXECUTABLE)
  endif()
  get_filename_component(urdf "${ARG_URDF}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/jrgen/${ARG_TARGET}")
  set(out_cpp "${out_dir}/${ARG_TARGET}.cpp")
  set(out_hpp "${out_dir}/${ARG_TARGET}.hpp")
  set(cmd "${exe}" "${urdf}" -o "${out_cpp}")
  # The program's file is a dependency, so a rebuilt or reinstalled jrgen
  # regenerates the solver.  It is named as a file ($<TARGET_FILE:...>), not
  # as a target: a target-level dependency alone does not make the rule depend
  # on the program's file.  In jrgen's own tree the generator expression on
  # the command line also gives the target-level dependency that builds jrgen
  # first.
  set(deps "${urdf}" "${exe}")
  if(ARG_CUTS)
    get_filename_component(cuts "${ARG_CUTS}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    list(APPEND cmd --cuts "${cuts}")
    list(APPEND deps "${cuts}")
  endif()
  if(ARG_NAMESPACE)
    list(APPEND cmd --namespace "${ARG_NAMESPACE}")
  endif()
  list(APPEND cmd ${ARG_OPTIONS})
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
  # The generated code checks every pivot before std::sqrt and never reads
  # errno: let the compiler emit the bare square-root instruction.
  target_compile_options(${ARG_TARGET} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-fno-math-errno>)
  set_target_properties(${ARG_TARGET} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()
