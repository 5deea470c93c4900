# The published benchmark problems (docs/simulation.md, "Published problems"): each model
# of models/ generated through add_jr_solver() with the gravity of its specification and
# compiled with -Werror; published_test checks sizes, the published initial states against
# the generated constraints, and Andrews' squeezer against a second implementation of the
# Test Set for IVP Solvers' equations (tests/published/andrews_testset.hpp).
set(_pub_models "${PROJECT_SOURCE_DIR}/models")
set(_pub_solvers
  "published_a01|iftomm_a01_pendulum|0,-9.81,0"
  "published_a02|iftomm_a02_nfourbar|0,-9.81,0"
  "published_andrews|andrews_squeezer|0,0,0"
  "published_a04|iftomm_a04_bricard|0,-9.81,0"
  "published_a05|iftomm_a05_flyball|0,0,-9.81")
set(_pub_targets "")
foreach(_entry IN LISTS _pub_solvers)
  string(REPLACE "|" ";" _entry "${_entry}")
  list(GET _entry 0 _target)
  list(GET _entry 1 _model)
  list(GET _entry 2 _gravity)
  add_jr_solver(TARGET ${_target} URDF "${_pub_models}/${_model}.urdf" NAMESPACE ${_target}
                OPTIONS --gravity ${_gravity})
  target_compile_options(${_target} PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Werror)
  list(APPEND _pub_targets ${_target})
endforeach()
# The N four-bar at its flat (singular) configuration, with the regularized solve.
add_jr_solver(TARGET published_a02_proximal URDF "${_pub_models}/iftomm_a02_nfourbar.urdf"
              NAMESPACE published_a02_proximal OPTIONS --gravity 0,-9.81,0 --singular proximal)
target_compile_options(published_a02_proximal PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Werror)

jrgen_test(published_test published/published_test.cpp)
target_link_libraries(published_test PRIVATE ${_pub_targets} published_a02_proximal Eigen3::Eigen)
target_include_directories(published_test PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_compile_definitions(published_test PRIVATE JRGEN_EXECUTABLE="$<TARGET_FILE:jrgen>")

# Work-precision of the simulation layer on the five problems (issue 21 item 3;
# docs/simulation.md, "Work-precision"): scripts/simulation_report.sh runs the full
# sweep and draws it; the ctest runs --quick (3 tolerances, short spans) and --check
# (errors fall as tol tightens, auto within 100 x tol of each reference).
add_executable(published_work_precision published/work_precision.cpp)
target_link_libraries(published_work_precision PRIVATE ${_pub_targets} published_a02_proximal jrgen_runtime)
target_compile_options(published_work_precision PRIVATE -Wall -Wextra -Wpedantic -Wshadow -Werror)
target_include_directories(published_work_precision PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_compile_definitions(published_work_precision PRIVATE JRGEN_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
add_test(NAME published_work_precision
         COMMAND published_work_precision --quick --check
                 -o ${CMAKE_CURRENT_BINARY_DIR}/published_work_precision_quick.tsv)
set_tests_properties(published_work_precision PROPERTIES TIMEOUT 300)
