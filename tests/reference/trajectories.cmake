# Independent reference trajectories (issue 29 item 1; docs/testing.md, "References"):
# trajectory_reference integrates the dynamics of tests/reference/ with SUNDIALS CVODE
# (libsundials-dev) and wrote the committed files tests/published/reference/*.tsv and
# tests/simulate/extreme/reference/*.tsv (scripts/make_trajectory_references.sh, minutes).
# The ctest trajectory_reference_reproduce recomputes the first rows of each file
# (seconds); trajectory_reference_test compares jrgen's runs with the files.
find_package(SUNDIALS REQUIRED CONFIG)
add_executable(trajectory_reference reference/trajectory_reference.cpp reference/reference_constraints.cpp
               reference/reference_forces.cpp)
target_link_libraries(trajectory_reference PRIVATE jrgen_test_support jrgen_urdf Eigen3::Eigen
                      SUNDIALS::cvode_shared SUNDIALS::nvecserial_shared SUNDIALS::sunlinsoldense_shared
                      SUNDIALS::sunmatrixdense_shared SUNDIALS::sunnonlinsolfixedpoint_shared)
target_compile_options(trajectory_reference PRIVATE -Wall -Wextra)
target_compile_definitions(trajectory_reference PRIVATE JRGEN_SOURCE_DIR="${PROJECT_SOURCE_DIR}")

if(NOT JRGEN_TEST_SUBSET)
  jrgen_test(trajectory_reference_test reference/trajectory_reference_test.cpp reference/reference_forces.cpp)
  target_include_directories(trajectory_reference_test PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/simulate
                             ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(trajectory_reference_test PRIVATE jrgen_runtime jrgen_test_support jrgen_urdf published_a02
                        published_a04 published_a05 ${_x_solvers})
  # Each committed file's first rows recomputed by the program that wrote it (rows 0-2:
  # 0.1 s; the 1e9 N/m spring's first 0.05 s, ~7e4 BDF steps, and the tops' first 0.01 s,
  # rows 0-1): the files are reproducible.  Not the rope's: its first 0.01 s alone took
  # 25 s on the loaded machine (50 links, ~1e4 right-hand sides of the reference); its
  # file is compared with jrgen over the whole span by trajectory_reference_test.
  foreach(_case a02 a02_reduced a04 a05 dp_light_tip_1e6 dp_light_tip_1e9 dp_light_tip_1e12 dp_heavy_tip_1e6
                dp_heavy_tip_1e9 point_spring_1e9 near_toggle parallelogram
                parallelogram_reduced parallelogram_reduced_flat top_100 top_1000 top_10000)
    if(_case MATCHES "^a0")
      set(_dir ${CMAKE_CURRENT_SOURCE_DIR}/published/reference)
    else()
      set(_dir ${CMAKE_CURRENT_SOURCE_DIR}/simulate/extreme/reference)
    endif()
    set(_rows 2)
    if(_case STREQUAL "point_spring_1e9" OR _case MATCHES "^top_")
      set(_rows 1)
    endif()
    add_test(NAME trajectory_reference_reproduce_${_case}
             COMMAND trajectory_reference ${_case} --reproduce ${_dir}/${_case}.tsv --rows ${_rows})
  endforeach()
endif()
