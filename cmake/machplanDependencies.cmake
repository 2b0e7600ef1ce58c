# The third-party packages machplan's libraries link, found the same way for machplan's own
# build (included by the top-level CMakeLists.txt) and for a project that uses an installed
# machplan (included by machplanConfig.cmake, which defines MACHPLAN_FIND_AS_DEPENDENCY so that
# a missing package is reported through find_package(machplan) instead of aborting).
#
# The libraries are static, so a consumer links the private dependencies too: every package
# below is needed by the consumer of the installed targets, not only by the headers.
if(MACHPLAN_FIND_AS_DEPENDENCY)
  include(CMakeFindDependencyMacro)
  macro(machplan_find_package)
    find_dependency(${ARGN})
  endmacro()
else()
  macro(machplan_find_package)
    find_package(${ARGN} REQUIRED)
  endmacro()
endif()

# Seen by the public headers: Eigen (vectors, transforms), fmt, nlohmann-json (to_json
# results), yaml-cpp (engine/config/yaml.h).
machplan_find_package(Eigen3 3.3 NO_MODULE)
machplan_find_package(fmt)
machplan_find_package(nlohmann_json 3)
machplan_find_package(yaml-cpp)
# Linked privately: FCL (engine/interference), OMPL (solvers/motion), Cairo (solvers: pictures),
# oneTBB (solvers/placement: the checker's and the searches' threads).
machplan_find_package(fcl)
machplan_find_package(TBB)
machplan_find_package(ompl)
if(NOT TARGET ompl::ompl)
  # OMPL 1.5 ships only variables; wrap them in a target so the rest of the build sees one name.
  add_library(ompl::ompl INTERFACE IMPORTED)
  set_target_properties(ompl::ompl PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${OMPL_INCLUDE_DIRS}"
                        INTERFACE_LINK_LIBRARIES "${OMPL_LIBRARIES}")
endif()
# Ceres (solvers/calibration/fit.cpp) and SQLite (solvers/calibration/store.cpp).
machplan_find_package(Ceres)
# NLopt (solvers/tuning: gain tuning; NLopt::nlopt).
machplan_find_package(NLopt)
machplan_find_package(SQLite3)
machplan_find_package(PkgConfig)
if(NOT TARGET PkgConfig::CAIRO)
  pkg_check_modules(CAIRO REQUIRED IMPORTED_TARGET cairo)
endif()
