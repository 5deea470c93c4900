# Vehicle trains (issue 4, item 3): k HMMWVs hitched by spherical cut joints
# (make_random_model train), k = 1, 4, 37, 371 (27 to 10 017 velocity
# coordinates).  One program per size (train_benchmark.cpp, compiled with the
# size's solver): forward_dynamics at the zero configuration, and
# solve_augmented for the sizes whose dense M fits comfortably (k <= 37).
# bench_scaling also links every size (each solver has its own namespace) to
# time them in one process.  Included from tests/bench/CMakeLists.txt; build
# the targets bench_train_<k>.  The 37- and 371-vehicle solvers are
# table-driven (Step 3 from 10 vehicles, Steps 1, 2, 4 from 25).
set(JRGEN_TRAIN_DIR "${CMAKE_CURRENT_BINARY_DIR}/trains")
file(MAKE_DIRECTORY "${JRGEN_TRAIN_DIR}")
set(JRGEN_TRAIN_SIZES 1 4 37 371 CACHE STRING "Vehicles per benchmarked train")
foreach(k ${JRGEN_TRAIN_SIZES})
  set(_urdf "${JRGEN_TRAIN_DIR}/train_${k}.urdf")
  set(_cuts "${JRGEN_TRAIN_DIR}/train_${k}.cuts.xml")
  add_custom_command(OUTPUT "${_urdf}" "${_cuts}"
    COMMAND make_random_model train --vehicles ${k} -o "${_urdf}"
    DEPENDS make_random_model "${PROJECT_SOURCE_DIR}/models/hmmwv14.urdf" "${PROJECT_SOURCE_DIR}/models/hmmwv14.cuts.xml"
    COMMENT "Writing a train of ${k} vehicles")
  add_custom_target(write_train_${k} DEPENDS "${_urdf}" "${_cuts}")
  add_jr_solver(TARGET bench_gen_train_${k} URDF "${_urdf}" CUTS "${_cuts}" NAMESPACE bench_gen_train_${k}
                OPTIONS --report "${JRGEN_TRAIN_DIR}/train_${k}.md")
  add_dependencies(bench_gen_train_${k} write_train_${k})
  add_executable(bench_train_${k} train_benchmark.cpp)
  target_link_libraries(bench_train_${k} PRIVATE bench_gen_train_${k} jrgen_bench_fixture benchmark::benchmark Eigen3::Eigen)
  target_compile_definitions(bench_train_${k} PRIVATE JRGEN_TRAIN_HEADER="bench_gen_train_${k}.hpp"
                             JRGEN_TRAIN_NS=bench_gen_train_${k} JRGEN_TRAIN_VEHICLES=${k})
  add_dependencies(jrgen_benchmarks bench_train_${k})
endforeach()
