# What `cmake --install BUILD [--prefix P]` puts where:
#
#   P/bin/machplan
#   P/lib/libmachplan_{engine,models,solvers}.a
#   P/include/machplan/{engine,models,solvers}/**.h      the public headers: every header except
#                                                          those in an internal/ folder and the
#                                                          HAL component's engine/hardware/hal/
#   P/lib/cmake/machplan/machplanConfig.cmake ...        find_package(machplan): machplan::engine,
#                                                          machplan::models, machplan::solvers
#   P/share/machplan/machines/*.yaml                      the bundled machines (--machine NAME)
#   P/share/machplan/datasets/{parts,profiles,programs,hexam-paper}/   the bundled inputs
#   P/share/machplan/panel/{index.html,panel.js,panel.css}   the page `machplan serve` serves
#
# A consumer includes <machplan/engine/...>; the installed headers include each other as
# "engine/...", which include/machplan on the include path resolves (docs/install.md).
include(CMakePackageConfigHelpers)

install(TARGETS machplan RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
install(TARGETS machplan_engine machplan_models machplan_solvers EXPORT machplanTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR})
# A header in an internal/ folder serves only its layer's own sources (text scanning, number
# parsing, setting checks, SQLite plumbing, the parts of one solver); no installed header may
# include one. engine/hardware/hal/ is the real-time component's C source (halcompile builds it,
# scripts/setup installs it), not a header of the libraries.
foreach(layer engine models solvers)
  install(DIRECTORY ${PROJECT_SOURCE_DIR}/${layer}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/machplan/${layer}
          FILES_MATCHING PATTERN "*.h" PATTERN internal EXCLUDE REGEX "/engine/hardware/hal$" EXCLUDE)
endforeach()

# Instrumented libraries need the same runtime in the program that links them.
if(MACHPLAN_SANITIZE)
  target_link_options(machplan_engine INTERFACE $<INSTALL_INTERFACE:-fsanitize=address,undefined>)
endif()

set(MACHPLAN_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/machplan)
install(EXPORT machplanTargets NAMESPACE machplan:: DESTINATION ${MACHPLAN_CMAKE_DIR})
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/machplanConfig.cmake.in
  ${PROJECT_BINARY_DIR}/machplanConfig.cmake INSTALL_DESTINATION ${MACHPLAN_CMAKE_DIR}
  PATH_VARS CMAKE_INSTALL_DATADIR)
write_basic_package_version_file(${PROJECT_BINARY_DIR}/machplanConfigVersion.cmake
  COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/machplanConfig.cmake ${PROJECT_BINARY_DIR}/machplanConfigVersion.cmake
        ${PROJECT_SOURCE_DIR}/cmake/machplanDependencies.cmake DESTINATION ${MACHPLAN_CMAKE_DIR})

install(DIRECTORY ${PROJECT_SOURCE_DIR}/datasets/machines/ DESTINATION ${CMAKE_INSTALL_DATADIR}/machplan/machines)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/datasets/ DESTINATION ${CMAKE_INSTALL_DATADIR}/machplan/datasets
        PATTERN machines EXCLUDE)
# The panel's page (cli/panel/web/), which an installed `machplan serve` finds beside it
# (cli/panel/server.cpp, web_root_folder()).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/cli/panel/web/ DESTINATION ${CMAKE_INSTALL_DATADIR}/machplan/panel)
