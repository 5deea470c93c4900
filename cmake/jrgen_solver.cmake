# add_jr_solver(TARGET <name> URDF <file> [CUTS <file>] [NAMESPACE <ns>] [OPTIONS <jrgen options>...])
#
# Generates <name>.cpp and <name>.hpp with jrgen at build time and compiles
# them into the static library <name>, linked with the jrgen runtime.  The
# generated header is on the target's include path (#include "<name>.hpp").
# The solver is regenerated when the URDF, the cuts file or jrgen changes.
# Relative paths are taken from the calling CMakeLists.txt's folder.
#
# Parallel variant (jrgen --threads, an extension beyond docs/interface.md): jrgen
# emits OpenMP code for large trees, and then the target must be compiled and
# linked with OpenMP (OpenMP::OpenMP_CXX).  add_jr_solver decides at configure
# time, with the generator's rule: OPTIONS --threads 1 never; --threads N >= 2
# always; otherwise (auto) when the URDF, read now, has at least
# JRGEN_MIN_PARALLEL_DOFS velocity coordinates (the generator's threshold).  A
# URDF that does not exist yet at configure time (written at build time) gets
# --threads 1 unless OPTIONS say otherwise.  Without an OpenMP compiler the
# parallel code is compiled serially (its pragmas sit under #ifdef _OPENMP).
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

set(JRGEN_MIN_PARALLEL_DOFS 10000)  # = emit::kMinParallelDofs

# Velocity coordinates of the joints of a URDF, counted from its text.
function(_jrgen_urdf_dofs urdf out)
  file(READ "${urdf}" text)
  string(REGEX MATCHALL "<joint[^>]*type=\"(revolute|continuous|prismatic|ball|planar|floating)\"" joints "${text}")
  set(n 0)
  foreach(j IN LISTS joints)
    if(j MATCHES "floating")
      math(EXPR n "${n} + 6")
    elseif(j MATCHES "\"(ball|planar)\"")
      math(EXPR n "${n} + 3")
    else()
      math(EXPR n "${n} + 1")
    endif()
  endforeach()
  set(${out} ${n} PARENT_SCOPE)
endfunction()

function(add_jr_solver)
  cmake_parse_arguments(ARG "" "TARGET;URDF;CUTS;NAMESPACE" "OPTIONS" ${ARGN})
  if(NOT ARG_TARGET OR NOT ARG_URDF)
    message(FATAL_ERROR "add_jr_solver: TARGET and URDF are required, e.g. add_jr_solver(TARGET robot_dyn URDF robot.urdf) "
                        "(docs/cmake.md)")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "add_jr_solver: unknown arguments: ${ARG_UNPARSED_ARGUMENTS}; the keywords are TARGET, URDF, "
                        "CUTS, NAMESPACE and OPTIONS (jrgen's options, such as --method ldlt, go after OPTIONS)")
  endif()
  list(REMOVE_ITEM ARG_KEYWORDS_MISSING_VALUES OPTIONS)  # an empty OPTIONS list is fine
  if(ARG_KEYWORDS_MISSING_VALUES)
    message(FATAL_ERROR "add_jr_solver: no value given for ${ARG_KEYWORDS_MISSING_VALUES}; give each keyword its "
                        "value, e.g. CUTS robot.cuts.xml")
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
  # Parallel variant: decide as jrgen does (see above).
  set(threads auto)
  list(FIND ARG_OPTIONS --threads at)
  if(at GREATER_EQUAL 0)
    math(EXPR at "${at} + 1")
    list(LENGTH ARG_OPTIONS len)
    if(at LESS len)
      list(GET ARG_OPTIONS ${at} threads)
    endif()
  endif()
  set(parallel OFF)
  if(threads MATCHES "^[0-9]+$")
    if(threads GREATER_EQUAL 2)
      set(parallel ON)
    endif()
  elseif(ARG_CUTS)
    # closed loops: always serial
  elseif(EXISTS "${urdf}")
    _jrgen_urdf_dofs("${urdf}" dofs)
    if(dofs GREATER_EQUAL JRGEN_MIN_PARALLEL_DOFS)
      set(parallel ON)
    endif()
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${urdf}")
  else()
    list(APPEND cmd --threads 1)
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
  # The generated code checks every pivot before std::sqrt and never reads
  # errno: let the compiler emit the bare square-root instruction.
  target_compile_options(${ARG_TARGET} PRIVATE $<$<CXX_COMPILER_ID:GNU,Clang>:-fno-math-errno>)
  # JRGEN_DISPATCH OFF (a variable of the calling scope): one copy of each
  # routine instead of the x86-64-v3 and baseline pair (docs/cmake.md).
  if(DEFINED JRGEN_DISPATCH AND NOT JRGEN_DISPATCH)
    target_compile_definitions(${ARG_TARGET} PRIVATE JRGEN_NO_DISPATCH)
  endif()
  set_target_properties(${ARG_TARGET} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  if(parallel)
    find_package(OpenMP QUIET COMPONENTS CXX)
    if(OpenMP_CXX_FOUND)
      target_link_libraries(${ARG_TARGET} PUBLIC OpenMP::OpenMP_CXX)
    else()
      message(WARNING "add_jr_solver(${ARG_TARGET}): no OpenMP for C++; the parallel variant runs serially")
    endif()
  endif()
endfunction()

# add_jr_simulator(TARGET <name> URDF <file> [CUTS <file>] [NAMESPACE <ns>] [OPTIONS <jrgen options>...])
#
# Builds the executable <name> that integrates the mechanism in time
# (docs/interface.md section 7, docs/simulation.md): the solver is generated by
# add_jr_solver(TARGET <name>_dyn ...) with the same arguments, and the
# simulator main (jrgen_simulator_main.cpp.in, beside this file) is
# configured with its header and namespace and linked with it and the
# runtime (<jrgen/simulate.hpp>).  Without NAMESPACE the namespace is
# jrsim_<name> (non-identifier characters of <name> made '_').
set_property(GLOBAL PROPERTY JRGEN_SIMULATOR_MAIN "${CMAKE_CURRENT_LIST_DIR}/jrgen_simulator_main.cpp.in")

function(add_jr_simulator)
  cmake_parse_arguments(ARG "" "TARGET;URDF;CUTS;NAMESPACE" "OPTIONS" ${ARGN})
  if(NOT ARG_TARGET OR NOT ARG_URDF)
    message(FATAL_ERROR "add_jr_simulator: TARGET and URDF are required, e.g. add_jr_simulator(TARGET robot_dyn URDF robot.urdf) "
                        "(docs/cmake.md)")
  endif()
  if(ARG_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "add_jr_simulator: unknown arguments: ${ARG_UNPARSED_ARGUMENTS}; the keywords are TARGET, URDF, "
                        "CUTS, NAMESPACE and OPTIONS (jrgen's options, such as --method ldlt, go after OPTIONS)")
  endif()
  set(ns "${ARG_NAMESPACE}")
  if(NOT ns)
    string(MAKE_C_IDENTIFIER "jrsim_${ARG_TARGET}" ns)
  endif()
  set(solver "${ARG_TARGET}_dyn")
  set(extra "")
  if(ARG_CUTS)
    list(APPEND extra CUTS "${ARG_CUTS}")
  endif()
  add_jr_solver(TARGET ${solver} URDF "${ARG_URDF}" ${extra} NAMESPACE ${ns} OPTIONS ${ARG_OPTIONS})
  get_property(main_in GLOBAL PROPERTY JRGEN_SIMULATOR_MAIN)
  set(JRGEN_SIM_HEADER "${solver}.hpp")
  set(JRGEN_SIM_NAMESPACE "${ns}")
  set(JRGEN_SIM_NAME "${ARG_TARGET}")
  set(main "${CMAKE_CURRENT_BINARY_DIR}/jrgen/${solver}/${ARG_TARGET}_main.cpp")
  configure_file("${main_in}" "${main}" @ONLY)
  add_executable(${ARG_TARGET} "${main}")
  target_link_libraries(${ARG_TARGET} PRIVATE ${solver})
endfunction()
