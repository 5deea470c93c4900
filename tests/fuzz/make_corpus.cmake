# Writes the seed corpus of tests/fuzz/fuzz_urdf.cpp into OUT (cmake -P, at
# build time; nothing is copied into the repository).  SRC is the source root.
#   - every URDF of models/, tests/cli/ and tests/errors/, as it is;
#   - each model of models/ with its cuts file, and every .cuts.xml of
#     tests/errors/ after tests/cli/cuts_base.urdf (the robot cli_test reads
#     them with), joined by the separator of tests/fuzz/fuzz_input.hpp.
set(_sep "\n<!--jrgen-fuzz-cuts-->\n")
file(REMOVE_RECURSE "${OUT}")
file(MAKE_DIRECTORY "${OUT}")
file(GLOB _urdfs "${SRC}/models/*.urdf" "${SRC}/tests/cli/*.urdf" "${SRC}/tests/errors/*.urdf")
foreach(_f IN LISTS _urdfs)
  get_filename_component(_dir "${_f}" DIRECTORY)
  get_filename_component(_dir "${_dir}" NAME)
  get_filename_component(_name "${_f}" NAME)
  configure_file("${_f}" "${OUT}/${_dir}_${_name}" COPYONLY)
endforeach()
function(_pair urdf cuts out)
  file(READ "${urdf}" _u)
  file(READ "${cuts}" _c)
  file(WRITE "${OUT}/${out}" "${_u}${_sep}${_c}")
endfunction()
file(GLOB _model_cuts "${SRC}/models/*.cuts.xml")
foreach(_c IN LISTS _model_cuts)
  get_filename_component(_name "${_c}" NAME)
  string(REPLACE ".cuts.xml" "" _stem "${_name}")
  _pair("${SRC}/models/${_stem}.urdf" "${_c}" "models_${_stem}_with_cuts")
endforeach()
file(GLOB _error_cuts "${SRC}/tests/errors/*.cuts.xml")
foreach(_c IN LISTS _error_cuts)
  get_filename_component(_name "${_c}" NAME)
  _pair("${SRC}/tests/cli/cuts_base.urdf" "${_c}" "errors_${_name}")
endforeach()
