# Start the longest tests first. ctest orders a run by the times it measured in earlier runs of
# the same build tree (Testing/Temporary/CTestCostData.txt); a fresh tree, as in CI, has none,
# so these would start wherever they fall in the list and the run would end on one of them
# alone. The costs are their seconds in a sanitized run on a 2-core machine; only their order
# matters. Included by ctest after the suites (tests/CMakeLists.txt); a name that is not in this
# build (the HAL suites without MACHPLAN_HAL) is passed over.
set_tests_properties(install_headers PROPERTIES COST 200)
set_tests_properties(Reproduction PROPERTIES COST 150)
set_tests_properties(Threads PROPERTIES COST 120)
set_tests_properties(install_downstream PROPERTIES COST 100)
set_tests_properties(Rotations PROPERTIES COST 90)
set_tests_properties(PanelApi PROPERTIES COST 80)
set_tests_properties(panel_browser PROPERTIES COST 40)
set_tests_properties(Trunnion PROPERTIES COST 40)
set_tests_properties(Checker Class1Parts Invasion Programs/GcodeConformance PROPERTIES COST 35)
# The HAL suites run one at a time (RESOURCE_LOCK hal), about three minutes in all: started
# early, that chain runs beside the others instead of after them.
set_tests_properties(HalRun PROPERTIES COST 170)
set_tests_properties(HalSetup PROPERTIES COST 160)
