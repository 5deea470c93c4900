# Optional Pinocchio (JRGEN_PINOCCHIO_SOURCE: a source tree of
# stack-of-tasks/pinocchio; 3.7.0 was measured).  Compiled header-only into
# jrgen_peers_pinocchio with its URDF parser's two source files; the few
# headers Pinocchio's own CMake would generate (version, export and
# deprecation macros) are written here into the build tree.  Nothing of
# Pinocchio is in the repository.  Needs Boost's headers (libboost-dev) and
# urdfdom (already a jrgen dependency).
set(_pin "${JRGEN_PINOCCHIO_SOURCE}")
if(NOT EXISTS "${_pin}/include/pinocchio/algorithm/aba.hpp" OR NOT EXISTS "${_pin}/src/parsers/urdf/model.cpp")
  message(FATAL_ERROR "JRGEN_PINOCCHIO_SOURCE=${_pin} is not a Pinocchio source tree")
endif()
find_package(Boost REQUIRED)
file(READ "${_pin}/package.xml" _pkg)
string(REGEX MATCH "<version>([0-9]+)\\.([0-9]+)\\.([0-9]+)</version>" _ "${_pkg}")
set(_maj "${CMAKE_MATCH_1}")
set(_min "${CMAKE_MATCH_2}")
set(_pat "${CMAKE_MATCH_3}")
message(STATUS "jrgen peers: Pinocchio ${_maj}.${_min}.${_pat} from ${_pin}")
set(_cfg "${CMAKE_CURRENT_BINARY_DIR}/pinocchio_config/pinocchio")
file(WRITE "${_cfg}/config.hpp" "#pragma once
#define PINOCCHIO_MAJOR_VERSION ${_maj}
#define PINOCCHIO_MINOR_VERSION ${_min}
#define PINOCCHIO_PATCH_VERSION ${_pat}
#define PINOCCHIO_VERSION \"${_maj}.${_min}.${_pat}\"
#define PINOCCHIO_VERSION_AT_LEAST(ma, mi, pa) \\
  (PINOCCHIO_MAJOR_VERSION > (ma) || (PINOCCHIO_MAJOR_VERSION == (ma) && \\
   (PINOCCHIO_MINOR_VERSION > (mi) || (PINOCCHIO_MINOR_VERSION == (mi) && PINOCCHIO_PATCH_VERSION >= (pa)))))
#define PINOCCHIO_DLLAPI
#define PINOCCHIO_LOCAL
")
file(WRITE "${_cfg}/deprecated.hpp" "#pragma once
#define PINOCCHIO_DEPRECATED __attribute__((deprecated))
#define PINOCCHIO_DEPRECATED_MESSAGE(message) __attribute__((deprecated(message)))
")
file(WRITE "${_cfg}/warning.hpp" "#pragma once\n#define PINOCCHIO_WARNING(object)\n")
foreach(_part parsers collision extra visualizers)
  string(TOUPPER "${_part}" _upper)
  file(WRITE "${_cfg}/${_part}/config.hpp"
       "#pragma once\n#define PINOCCHIO_${_upper}_DLLAPI\n#define PINOCCHIO_${_upper}_LOCAL\n")
endforeach()

add_library(jrgen_peers_pinocchio STATIC pinocchio_side.cpp "${_pin}/src/parsers/urdf/model.cpp"
            "${_pin}/src/parsers/urdf/utils.cpp")
target_include_directories(jrgen_peers_pinocchio PRIVATE "${CMAKE_CURRENT_SOURCE_DIR}"
                           "${CMAKE_CURRENT_BINARY_DIR}/pinocchio_config" "${_pin}/include")
target_compile_definitions(jrgen_peers_pinocchio PRIVATE PINOCCHIO_WITH_URDFDOM JRGEN_PEERS_PINOCCHIO)
target_link_libraries(jrgen_peers_pinocchio PRIVATE Eigen3::Eigen Boost::boost ${urdfdom_LIBRARIES})
target_compile_features(jrgen_peers_pinocchio PRIVATE cxx_std_17)
target_compile_definitions(jrgen_peers_core PUBLIC JRGEN_PEERS_PINOCCHIO)
target_link_libraries(jrgen_peers_core PRIVATE jrgen_peers_pinocchio)
