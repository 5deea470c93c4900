# CLI and golden tests: they run the real jrgen binary (tests/generator/cli_test.cpp,
# golden_test.cpp, assembly_cli_test.cpp; helpers in tests/cli/run_jrgen.hpp).  Included at the end of
# tests/CMakeLists.txt, so relative paths are relative to tests/.

foreach(_t cli_test golden_test assembly_cli_test)
  jrgen_test(${_t} generator/${_t}.cpp)
  target_include_directories(${_t} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_compile_definitions(${_t} PRIVATE JRGEN_EXECUTABLE="$<TARGET_FILE:jrgen>")
  target_compile_features(${_t} PRIVATE cxx_std_20)
  add_dependencies(${_t} jrgen)
endforeach()

# --graph, --sparsity: the pictures' text (emit/graph.cpp) and the command line.
jrgen_test(graph_test generator/graph_test.cpp)
target_include_directories(graph_test PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_compile_definitions(graph_test PRIVATE JRGEN_EXECUTABLE="$<TARGET_FILE:jrgen>")
target_compile_features(graph_test PRIVATE cxx_std_20)
target_link_libraries(graph_test PRIVATE jrgen_emit jrgen_model_cases jrgen_topology)
add_dependencies(graph_test jrgen)

# Refreshes tests/golden/*/solver.{cpp,hpp} in the source tree from the current
# jrgen; review the result with `git diff tests/golden` before committing.
add_custom_target(update_goldens
  COMMAND ${CMAKE_COMMAND} -E env JRGEN_UPDATE_GOLDENS=1 $<TARGET_FILE:golden_test> --gtest_filter=Cases/Golden.*
  COMMAND ${CMAKE_COMMAND} -E echo "Goldens refreshed: review with git diff -- ${CMAKE_CURRENT_SOURCE_DIR}/golden"
  DEPENDS golden_test jrgen
  WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR}
  COMMENT "Regenerating tests/golden from jrgen"
  VERBATIM)

# Processor dispatch: which generated definitions get both copies (emit/dispatch.cpp).
jrgen_test(dispatch_test generator/dispatch_test.cpp)
target_link_libraries(dispatch_test PRIVATE jrgen_emit)
