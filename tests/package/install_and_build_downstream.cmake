# cmake -DJRGEN_SOURCE_DIR=... -DJRGEN_BINARY_DIR=... -DWORK_DIR=... [-DCONFIG=...]
#       [-DGENERATOR=...] [-DMAKE_PROGRAM=...] [-DCXX_COMPILER=...] [-DEIGEN3_DIR=...]
#       [-DBINDIR=bin] [-DLIBDIR=lib] [-DINCLUDEDIR=include]
#       -P install_and_build_downstream.cmake
#
# 1. cmake --install JRGEN_BINARY_DIR --prefix WORK_DIR/prefix, and check the
#    package's files.
# 2. Configure examples/downstream against that prefix only, with
#    JRGEN_MODELS_DIR pointing at a copy of models/ in WORK_DIR; build; run.
# 3. Rebuild: nothing regenerated.  Touch the URDF copy: regenerated.  Touch
#    the installed jrgen: regenerated.  Run again.
# 4. The same for tests/package/solver_project (relative paths, CUTS,
#    OPTIONS, a shared library), touching its cuts file.
cmake_minimum_required(VERSION 3.20)

foreach(var JRGEN_SOURCE_DIR JRGEN_BINARY_DIR WORK_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "install_and_build_downstream.cmake: ${var} is not set")
  endif()
endforeach()
foreach(var BINDIR LIBDIR INCLUDEDIR)
  string(TOLOWER "${var}" default)
  string(REPLACE "dir" "" default "${default}")
  if(NOT ${var})
    set(${var} "${default}")
  endif()
endforeach()

set(prefix "${WORK_DIR}/prefix")
set(models "${WORK_DIR}/models")
set(message_re "jrgen: generating")

# run(<step> <output variable> COMMAND ...): runs the command, fails the test
# with its output when it fails, and returns stdout+stderr.
function(run step out)
  execute_process(${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE text ERROR_VARIABLE text)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${step} failed (${rc}):\n${ARGN}\n${text}")
  endif()
  message(STATUS "${step}: ok")
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# The build step; expect_generation is TRUE or FALSE.
function(build step dir expect_generation)
  set(args --build "${dir}")
  if(CONFIG)
    list(APPEND args --config "${CONFIG}")
  endif()
  run("${step}" text COMMAND "${CMAKE_COMMAND}" ${args})
  string(FIND "${text}" "${message_re}" at)
  if(expect_generation AND at EQUAL -1)
    message(FATAL_ERROR "${step}: expected jrgen to regenerate the solver; build output:\n${text}")
  elseif(NOT expect_generation AND NOT at EQUAL -1)
    message(FATAL_ERROR "${step}: expected no regeneration; build output:\n${text}")
  endif()
endfunction()

function(configure step src dir)
  set(args -S "${src}" -B "${dir}" "-DCMAKE_PREFIX_PATH=${prefix}"
           -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF ${ARGN})
  if(GENERATOR)
    list(APPEND args -G "${GENERATOR}")
  endif()
  if(MAKE_PROGRAM)
    list(APPEND args "-DCMAKE_MAKE_PROGRAM=${MAKE_PROGRAM}")
  endif()
  if(CXX_COMPILER)
    list(APPEND args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
  endif()
  if(EIGEN3_DIR)
    list(APPEND args "-DEigen3_DIR=${EIGEN3_DIR}")
  endif()
  if(CONFIG)
    list(APPEND args "-DCMAKE_BUILD_TYPE=${CONFIG}")
  endif()
  run("${step}" text COMMAND "${CMAKE_COMMAND}" ${args})
  # It must be this package, not some other jrgen on the machine.
  file(STRINGS "${dir}/CMakeCache.txt" jrgen_dir REGEX "^jrgen_DIR:")
  if(NOT jrgen_dir STREQUAL "jrgen_DIR:PATH=${prefix}/${LIBDIR}/cmake/jrgen")
    message(FATAL_ERROR "${step}: found the wrong jrgen package: ${jrgen_dir}")
  endif()
endfunction()

# The program, in <dir> or <dir>/<config> (multi-config generators).
function(run_program step dir name expect)
  set(exe "${dir}/${name}")
  if(NOT EXISTS "${exe}" AND CONFIG)
    set(exe "${dir}/${CONFIG}/${name}")
  endif()
  run("${step}" text COMMAND "${exe}")
  message("${text}")
  if(NOT text MATCHES "${expect}")
    message(FATAL_ERROR "${step}: output does not match '${expect}'")
  endif()
endfunction()

# Makes <file> newer than anything built so far, whatever the timestamp
# resolution of the file system and the build tool.
function(touch_later file)
  execute_process(COMMAND "${CMAKE_COMMAND}" -E sleep 1.1)
  file(TOUCH "${file}")
endfunction()

# ---- 1. install ------------------------------------------------------------------
file(REMOVE_RECURSE "${WORK_DIR}")
file(MAKE_DIRECTORY "${WORK_DIR}" "${models}")
set(args --install "${JRGEN_BINARY_DIR}" --prefix "${prefix}")
if(CONFIG)
  list(APPEND args --config "${CONFIG}")
endif()
run("install" text COMMAND "${CMAKE_COMMAND}" ${args})

set(jrgen_exe "${prefix}/${BINDIR}/jrgen${CMAKE_EXECUTABLE_SUFFIX}")
foreach(f "${jrgen_exe}"
          "${prefix}/${LIBDIR}/libjrgen_runtime.a"
          "${prefix}/${INCLUDEDIR}/jrgen/runtime.hpp"
          "${prefix}/${LIBDIR}/cmake/jrgen/jrgenConfig.cmake"
          "${prefix}/${LIBDIR}/cmake/jrgen/jrgenConfigVersion.cmake"
          "${prefix}/${LIBDIR}/cmake/jrgen/jrgenTargets.cmake"
          "${prefix}/${LIBDIR}/cmake/jrgen/jrgen_solver.cmake"
          "${prefix}/${LIBDIR}/cmake/jrgen/jrgen_simulator_main.cpp.in"
          "${prefix}/${INCLUDEDIR}/jrgen/simulate.hpp")
  if(NOT EXISTS "${f}")
    message(FATAL_ERROR "install: ${f} is missing")
  endif()
endforeach()
file(READ "${prefix}/${LIBDIR}/cmake/jrgen/jrgenTargets.cmake" targets)
foreach(re "add_executable\\(jrgen::jrgen IMPORTED\\)" "add_library\\(jrgen::runtime STATIC IMPORTED\\)"
           "INTERFACE_LINK_LIBRARIES \"Eigen3::Eigen\"")
  if(NOT targets MATCHES "${re}")
    message(FATAL_ERROR "install: jrgenTargets.cmake does not match '${re}'")
  endif()
endforeach()
run("installed jrgen --version" text COMMAND "${jrgen_exe}" --version)

# ---- 2, 3. examples/downstream -------------------------------------------------
configure_file("${JRGEN_SOURCE_DIR}/models/hmmwv14.urdf" "${models}/hmmwv14.urdf" COPYONLY)
set(ds_build "${WORK_DIR}/downstream-build")
configure("downstream: configure" "${JRGEN_SOURCE_DIR}/examples/downstream" "${ds_build}"
          "-DJRGEN_MODELS_DIR=${models}")
build("downstream: build" "${ds_build}" TRUE)
run_program("downstream: run" "${ds_build}" app "OK")
set(sim "${ds_build}/hmmwv_sim")
if(NOT EXISTS "${sim}" AND CONFIG)
  set(sim "${ds_build}/${CONFIG}/hmmwv_sim")
endif()
run("downstream: simulator (add_jr_simulator)" text COMMAND "${sim}" --t-end 0.01)
if(NOT text MATCHES "t=0.01 steps=[1-9]")
  message(FATAL_ERROR "downstream: simulator: '${text}'")
endif()
build("downstream: rebuild, nothing changed" "${ds_build}" FALSE)
touch_later("${models}/hmmwv14.urdf")
build("downstream: rebuild after touching the URDF" "${ds_build}" TRUE)
build("downstream: rebuild once more" "${ds_build}" FALSE)
touch_later("${jrgen_exe}")
build("downstream: rebuild after touching the installed jrgen" "${ds_build}" TRUE)
run_program("downstream: run again" "${ds_build}" app "OK")

# ---- 4. tests/package/solver_project ---------------------------------------------
set(sp_src "${WORK_DIR}/solver_project")
set(sp_build "${WORK_DIR}/solver_project-build")
file(COPY "${CMAKE_CURRENT_LIST_DIR}/solver_project/" DESTINATION "${sp_src}")
configure_file("${JRGEN_SOURCE_DIR}/models/arm7.urdf" "${sp_src}/models/arm7.urdf" COPYONLY)
configure("solver_project: configure" "${sp_src}" "${sp_build}")
build("solver_project: build" "${sp_build}" TRUE)
run_program("solver_project: run" "${sp_build}" arm_app "forward_dynamics -> 0")
touch_later("${sp_src}/models/arm7.cuts.xml")
build("solver_project: rebuild after touching the cuts file" "${sp_build}" TRUE)
touch_later("${sp_src}/models/arm7.urdf")
build("solver_project: rebuild after touching the URDF" "${sp_build}" TRUE)
build("solver_project: rebuild, nothing changed" "${sp_build}" FALSE)

message(STATUS "package test passed")
