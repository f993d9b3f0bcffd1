# xp_add_gtest(<name> SOURCES ... LINK ...): one GoogleTest executable, discovered at test time
# (not at build time, which would run every test binary on every build).
function(xp_add_gtest name)
  cmake_parse_arguments(arg "" "" "SOURCES;LINK;LABELS" ${ARGN})
  add_executable(${name} ${arg_SOURCES})
  target_link_libraries(${name} PRIVATE ${arg_LINK} GTest::gtest_main)
  # Testing/ holds helpers shared by the modules' tests (the reference geometry).
  target_include_directories(${name} PRIVATE "${PROJECT_SOURCE_DIR}/Testing")
  target_compile_definitions(${name} PRIVATE
    XP_SHARED_DATA_DIR="${PROJECT_SOURCE_DIR}/../shared/data"
    XP_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  # One label per test: gtest_discover_tests passes PROPERTIES on as separate words, so a list
  # of labels ("unit;pacs") would turn into a property named "pacs".
  set(labels unit)
  if(arg_LABELS)
    set(labels ${arg_LABELS})
  endif()
  gtest_discover_tests(${name} DISCOVERY_MODE PRE_TEST
    WORKING_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}"
    PROPERTIES LABELS "${labels}" TIMEOUT 600)
endfunction()
