# cmake -DJRGEN_SOURCE_DIR=... -DWORK_DIR=... -DMODE=subdirectory|fetchcontent [-DBUILD=ON]
#       [-DGENERATOR=...] [-DMAKE_PROGRAM=...] [-DCXX_COMPILER=...] [-DEIGEN3_DIR=...]
#       [-DJRGEN_PROGRAM=<a built jrgen>] -P subproject_test.cmake
# Configures tests/package/subproject with jrgen pulled in by MODE; with
# BUILD=ON also builds it (jrgen, its runtime and a generated arm7 solver),
# runs the program and checks its line "arm7: forward_dynamics -> 0, qdd[0] =
# <finite number>".  Debug without -g (-O0) keeps the compile of jrgen short.
# JRGEN_PROGRAM: the subproject generates with that program (its option
# JRGEN_GENERATOR) and does not compile its own generator.
cmake_minimum_required(VERSION 3.20)
foreach(var JRGEN_SOURCE_DIR WORK_DIR MODE)
  if(NOT ${var})
    message(FATAL_ERROR "subproject_test.cmake: ${var} is not set")
  endif()
endforeach()
set(dir "${WORK_DIR}/${MODE}")
file(REMOVE_RECURSE "${dir}")
set(args -S "${CMAKE_CURRENT_LIST_DIR}/subproject" -B "${dir}" "-DJRGEN_SOURCE=${JRGEN_SOURCE_DIR}"
         "-DMODE=${MODE}" -DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=-O0")  # the quickest full build
foreach(pair GENERATOR:-G MAKE_PROGRAM:-DCMAKE_MAKE_PROGRAM= CXX_COMPILER:-DCMAKE_CXX_COMPILER=
             EIGEN3_DIR:-DEigen3_DIR= LAUNCHER:-DCMAKE_CXX_COMPILER_LAUNCHER= JRGEN_PROGRAM:-DJRGEN_GENERATOR=)
  string(REPLACE ":" ";" pair "${pair}")
  list(GET pair 0 var)
  list(GET pair 1 flag)
  if(${var})
    if(flag STREQUAL "-G")
      list(APPEND args -G "${${var}}")
    else()
      list(APPEND args "${flag}${${var}}")
    endif()
  endif()
endforeach()
function(run step)
  execute_process(${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE text ERROR_VARIABLE text)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${step} failed (${rc}):\n${text}")
  endif()
  message(STATUS "${step}: ok")
  set(output "${text}" PARENT_SCOPE)
endfunction()
run("configure (${MODE})" COMMAND "${CMAKE_COMMAND}" ${args})
if(BUILD)
  run("build (${MODE})" COMMAND "${CMAKE_COMMAND}" --build "${dir}" -j2 --target app)
  run("run (${MODE})" COMMAND "${dir}/app")
  if(NOT output MATCHES "arm7: forward_dynamics -> 0, qdd\\[0\\] = -?[0-9]")
    message(FATAL_ERROR "run (${MODE}): unexpected output: ${output}")
  endif()
endif()
file(REMOVE_RECURSE "${dir}")
