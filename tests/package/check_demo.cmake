# The README's demo (examples/demo), run as a user runs it, its output checked:
#   cmake -DDEMO=<jrgen_demo> -DURDF=<its model> -P check_demo.cmake
# * exit status 0;
# * the sizes it prints (nq, nv, joints) equal those counted here from the
#   URDF's joint types (docs/interface.md section 3: floating 7/6, ball 4/3,
#   revolute, continuous and prismatic 1/1, fixed none), and nc > 0 (the
#   HMMWV's cuts);
# * the relative errors of qdd and of Phiq^T lambda against its dense
#   reference (LU of eq. (17), refined once in long double) at most 1e-9,
#   the closed-loop bound of docs/testing.md ("What the suite checks").
cmake_minimum_required(VERSION 3.20)
execute_process(COMMAND "${DEMO}" RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message(STATUS "${out}${err}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "jrgen_demo exited ${rc}")
endif()

file(READ "${URDF}" urdf)
string(REGEX MATCHALL "<joint[^>]*type=\"[a-z]+\"" joints "${urdf}")
set(nq 0)
set(nv 0)
set(nj 0)
foreach(j IN LISTS joints)
  string(REGEX REPLACE ".*type=\"([a-z]+)\"" "\\1" type "${j}")
  if(type STREQUAL "floating")
    math(EXPR nq "${nq} + 7")
    math(EXPR nv "${nv} + 6")
  elseif(type STREQUAL "ball")
    math(EXPR nq "${nq} + 4")
    math(EXPR nv "${nv} + 3")
  elseif(type MATCHES "^(revolute|continuous|prismatic)$")
    math(EXPR nq "${nq} + 1")
    math(EXPR nv "${nv} + 1")
  elseif(NOT type STREQUAL "fixed")
    message(FATAL_ERROR "check_demo.cmake: joint type '${type}' not counted here")
  endif()
  if(NOT type STREQUAL "fixed")
    math(EXPR nj "${nj} + 1")
  endif()
endforeach()
set(sizes "nq = ${nq}, nv = ${nv}, nc = [1-9][0-9]*, joints = ${nj}")
if(NOT out MATCHES "  ${sizes}\n")
  message(FATAL_ERROR "jrgen_demo: no line '${sizes}' (counted from ${URDF})")
endif()

foreach(what "relative error of qdd against the dense reference" "relative error of Phiq\\^T lambda")
  if(NOT out MATCHES "${what}: *([0-9.]+e[-+][0-9]+)\n")
    message(FATAL_ERROR "jrgen_demo: no line '${what}: <number>'")
  endif()
  set(e "${CMAKE_MATCH_1}")
  # if(LESS_EQUAL) compares numbers in exponent notation as doubles.
  if(NOT e LESS_EQUAL 1e-9)
    message(FATAL_ERROR "jrgen_demo: ${what} ${e} above 1e-9")
  endif()
endforeach()
if(NOT out MATCHES "forward_dynamics \\(kinematics \\+ M \\+ h \\+ solve\\): +[0-9.]+ us")
  message(FATAL_ERROR "jrgen_demo: no time per forward_dynamics call")
endif()
message(STATUS "check_demo: sizes ${nq}/${nv}/${nj} as counted from the URDF, errors within 1e-9")
