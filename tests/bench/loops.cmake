# Closed loops, issue 3: the HMMWV augmented solve (eq. 17, 27 + 16 = 43
# unknowns) generated with llt and ldlt, against the paper's Gauss (Eigen
# PartialPivLU of the 43 x 43 augmented matrix) and Alg-D (the same algorithm
# with dense Eigen Cholesky), all in one program on one assembled state
# (loops_benchmark.cpp).  Included at the end of tests/bench/CMakeLists.txt;
# build the single target bench_hmmwv14_loops.
set(JRGEN_LOOPS_OPS_DIR "${CMAKE_CURRENT_BINARY_DIR}/ops")
file(MAKE_DIRECTORY "${JRGEN_LOOPS_OPS_DIR}")
add_jr_solver(TARGET bench_gen_hmmwv14_loops
              URDF "${PROJECT_SOURCE_DIR}/models/hmmwv14.urdf"
              CUTS "${PROJECT_SOURCE_DIR}/models/hmmwv14.cuts.xml"
              NAMESPACE bench_gen_hmmwv14_loops
              OPTIONS --report "${JRGEN_LOOPS_OPS_DIR}/hmmwv14_loops.md")
add_jr_solver(TARGET bench_gen_hmmwv14_loops_ldlt
              URDF "${PROJECT_SOURCE_DIR}/models/hmmwv14.urdf"
              CUTS "${PROJECT_SOURCE_DIR}/models/hmmwv14.cuts.xml"
              NAMESPACE bench_gen_hmmwv14_loops_ldlt
              OPTIONS --method ldlt --report "${JRGEN_LOOPS_OPS_DIR}/hmmwv14_loops_ldlt.md")

add_executable(bench_hmmwv14_loops loops_benchmark.cpp)
target_link_libraries(bench_hmmwv14_loops PRIVATE
  bench_gen_hmmwv14_loops bench_gen_hmmwv14_loops_ldlt benchmark::benchmark Eigen3::Eigen)
target_compile_features(bench_hmmwv14_loops PRIVATE cxx_std_20)
# The report files, for the operation counts printed beside the times.
target_compile_definitions(bench_hmmwv14_loops PRIVATE
  JRGEN_LOOPS_OPS_LLT="${JRGEN_LOOPS_OPS_DIR}/hmmwv14_loops.md"
  JRGEN_LOOPS_OPS_LDLT="${JRGEN_LOOPS_OPS_DIR}/hmmwv14_loops_ldlt.md")
add_dependencies(jrgen_benchmarks bench_hmmwv14_loops)
