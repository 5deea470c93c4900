# The README's API snippet (examples/readme_snippet/snippet.cpp) compiled with
# -Wall -Wextra -Wpedantic -Werror against a tree (models/arm7.urdf, nc = 0)
# and a closed loop (models/hmmwv14.urdf + cuts, nc = 16), and run once
# (readme_snippet.tree, readme_snippet.loops); readme_snippet.quoted checks
# that README.md quotes the file verbatim.  Included from tests/CMakeLists.txt.
#
# The snippet includes "hmmwv_dyn.hpp" and uses namespace hmmwv, as the README
# says; each variant's solver is generated in namespace hmmwv under its own
# target, and a one-line hmmwv_dyn.hpp in a folder of its own includes it.
if(NOT JRGEN_TEST_SUBSET)
  set(_models "${PROJECT_SOURCE_DIR}/models")
  foreach(_variant tree loops)
    set(_target readme_snippet_${_variant}_dyn)
    if(_variant STREQUAL "tree")
      add_jr_solver(TARGET ${_target} URDF "${_models}/arm7.urdf" NAMESPACE hmmwv)
    else()
      add_jr_solver(TARGET ${_target} URDF "${_models}/hmmwv14.urdf" CUTS "${_models}/hmmwv14.cuts.xml"
                    NAMESPACE hmmwv)
    endif()
    target_compile_options(${_target} PRIVATE -Wall -Wextra -Wpedantic -Werror)
    set(_shim "${CMAKE_CURRENT_BINARY_DIR}/readme_snippet/${_variant}")
    file(WRITE "${_shim}/hmmwv_dyn.hpp.in" "#pragma once\n#include \"${_target}.hpp\"\n")
    configure_file("${_shim}/hmmwv_dyn.hpp.in" "${_shim}/hmmwv_dyn.hpp" COPYONLY)
    add_executable(readme_snippet_${_variant} "${PROJECT_SOURCE_DIR}/examples/readme_snippet/snippet.cpp"
                   "${CMAKE_CURRENT_LIST_DIR}/main.cpp")
    target_include_directories(readme_snippet_${_variant} PRIVATE "${_shim}")
    target_link_libraries(readme_snippet_${_variant} PRIVATE ${_target})
    target_compile_options(readme_snippet_${_variant} PRIVATE -Wall -Wextra -Wpedantic -Werror)
    add_test(NAME readme_snippet.${_variant} COMMAND readme_snippet_${_variant})
  endforeach()
endif()
add_test(NAME readme_snippet.quoted
  COMMAND "${CMAKE_COMMAND}" "-DREADME=${PROJECT_SOURCE_DIR}/README.md"
          "-DSNIPPET=${PROJECT_SOURCE_DIR}/examples/readme_snippet/snippet.cpp"
          -P "${CMAKE_CURRENT_LIST_DIR}/check_quoted.cmake")
