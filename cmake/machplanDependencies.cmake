# The third-party packages machplan's libraries link, found the same way for machplan's own
# build (included by the top-level CMakeLists.txt) and for a project that uses an installed
# machplan (included by machplanConfig.cmake, which defines MACHPLAN_FIND_AS_DEPENDENCY so that
# a missing package is reported through find_package(machplan) instead of aborting).
#
# The libraries are static, so a consumer links the private dependencies too: every package
# below but nlohmann-json is needed by the consumer of the installed targets, though only
# Eigen and fmt are seen by the headers.
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

# Seen by the public headers: Eigen (points, vectors, transforms) and fmt (messages), nothing
# else; the install test (tests/install) compiles every installed header with only these.
machplan_find_package(Eigen3 3.3 NO_MODULE)
machplan_find_package(fmt)

# Linked privately: no public header includes them, but the libraries are static, so whatever
# links machplan links these too. yaml-cpp (engine/config/yaml.cpp, behind Yaml), FCL
# (engine/interference/collision.cpp, behind Shape), OMPL (solvers/motion), Ceres
# (solvers/calibration/fit.cpp), NLopt (solvers/tuning/optimizer.cpp), SQLite
# (solvers/common/internal/sqlite_db.cpp, behind SqliteDb), Cairo (solvers/common/picture.cpp, behind
# Canvas), oneTBB (solvers/placement: the checker's and the searches' threads).
machplan_find_package(yaml-cpp)
machplan_find_package(fcl)
machplan_find_package(TBB)
machplan_find_package(ompl)
if(NOT TARGET ompl::ompl)
  # OMPL 1.5 ships only variables; wrap them in a target so the rest of the build sees one name.
  add_library(ompl::ompl INTERFACE IMPORTED)
  set_target_properties(ompl::ompl PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${OMPL_INCLUDE_DIRS}"
                        INTERFACE_LINK_LIBRARIES "${OMPL_LIBRARIES}")
endif()
machplan_find_package(Ceres)
machplan_find_package(NLopt)
machplan_find_package(SQLite3)
machplan_find_package(PkgConfig)
if(NOT TARGET PkgConfig::CAIRO)
  pkg_check_modules(CAIRO REQUIRED IMPORTED_TARGET cairo)
endif()

# nlohmann-json (headers only) is for machplan's own build: the stored fits and gains in
# solvers/ and the --json forms in cli/json/. The installed libraries do not ask for it (the
# solvers link it as a build-only dependency), so a consumer needs it only to use it itself.
if(NOT MACHPLAN_FIND_AS_DEPENDENCY)
  machplan_find_package(nlohmann_json 3)
endif()

# LinuxCNC's HAL, for the HAL backend only (engine/hardware/hal_backend.cpp, behind HalBackend),
# which is optional: MACHPLAN_HAL (AUTO, ON or OFF, top-level CMakeLists.txt) decides, and
# MACHPLAN_WITH_HAL says what was decided. linuxcnc-uspace-dev ships hal.h and rtapi.h under
# include/linuxcnc and liblinuxcnchal, with no pkg-config or CMake file. The headers are given
# to that one source file (engine/CMakeLists.txt); the library is linked privately. An
# installed machplan built without the HAL backend asks its consumers for nothing of LinuxCNC
# (machplanConfig.cmake passes its MACHPLAN_WITH_HAL down), one built with it needs the library.
if(MACHPLAN_FIND_AS_DEPENDENCY)
  if(NOT MACHPLAN_WITH_HAL OR TARGET machplan::linuxcnc_hal)
    return()
  endif()
  find_library(MACHPLAN_LINUXCNC_HAL_LIBRARY linuxcnchal)
  if(NOT MACHPLAN_LINUXCNC_HAL_LIBRARY)
    set(machplan_FOUND FALSE)
    set(machplan_NOT_FOUND_MESSAGE "this machplan was built with the HAL backend and needs LinuxCNC's liblinuxcnchal, which was not found: install linuxcnc-uspace-dev")
    return()
  endif()
elseif(MACHPLAN_HAL STREQUAL "OFF")
  set(MACHPLAN_WITH_HAL OFF)
  message(STATUS "HAL backend: off (MACHPLAN_HAL=OFF)")
  return()
else()
  if(NOT MACHPLAN_HAL MATCHES "^(AUTO|ON)$")
    message(FATAL_ERROR "MACHPLAN_HAL must be AUTO, ON or OFF (got '${MACHPLAN_HAL}')")
  endif()
  find_path(MACHPLAN_LINUXCNC_INCLUDE_DIR hal.h PATH_SUFFIXES linuxcnc)
  find_library(MACHPLAN_LINUXCNC_HAL_LIBRARY linuxcnchal)
  if(NOT MACHPLAN_LINUXCNC_HAL_LIBRARY OR NOT MACHPLAN_LINUXCNC_INCLUDE_DIR)
    set(_machplan_hal_missing "LinuxCNC's HAL (liblinuxcnchal and include/linuxcnc/hal.h) not found (linuxcnc-uspace-dev, which scripts/setup installs)")
    if(MACHPLAN_HAL STREQUAL "ON")
      message(FATAL_ERROR "MACHPLAN_HAL=ON but ${_machplan_hal_missing}")
    endif()
    set(MACHPLAN_WITH_HAL OFF)
    message(STATUS "HAL backend: off, ${_machplan_hal_missing}; the rest builds without it")
    return()
  endif()
  set(MACHPLAN_WITH_HAL ON)
  message(STATUS "HAL backend: on (${MACHPLAN_LINUXCNC_HAL_LIBRARY})")
endif()
if(NOT TARGET machplan::linuxcnc_hal)
  add_library(machplan::linuxcnc_hal UNKNOWN IMPORTED)
  set_target_properties(machplan::linuxcnc_hal PROPERTIES IMPORTED_LOCATION "${MACHPLAN_LINUXCNC_HAL_LIBRARY}")
endif()
