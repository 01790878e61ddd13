# splitvk_label_discovered_tests(<target> <label>...)
# gtest_discover_tests (CMake 3.25) flattens list values in PROPERTIES: `LABELS "unit;sanitize"`
# comes out as LABELS=unit plus a bogus property "sanitize" that swallows what follows. So labels
# are set by an include file that ctest reads after the discovered tests.
function(splitvk_label_discovered_tests target)
  set(labels_file ${CMAKE_CURRENT_BINARY_DIR}/${target}_labels.cmake)
  file(WRITE ${labels_file}
       "if(${target}_TESTS)\n  set_tests_properties(\${${target}_TESTS} PROPERTIES LABELS \"${ARGN}\")\nendif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${labels_file})
endfunction()
