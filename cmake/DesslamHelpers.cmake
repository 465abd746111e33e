# The install layout (CMAKE_INSTALL_LIBDIR, ...): src/core compiles in where share/desslam lies
# relative to it, src/api and cmake/DesslamInstall.cmake install there.
include(GNUInstallDirs)
# install() rules that name no component belong to the runtime package (cmake/DesslamInstall.cmake).
set(CMAKE_INSTALL_DEFAULT_COMPONENT_NAME runtime)

# desslam_add_library(<stage> SOURCES ... [DEPS ...])
#   builds desslam_<stage> from src/<stage>; public include root is src/ so headers are
#   included as "<stage>/header.hpp". Internal: static (position-independent), linked into the
#   shared desslam::desslam (src/api) and directly into the program and the tests; never installed.
function(desslam_add_library stage)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(desslam_${stage} STATIC ${ARG_SOURCES})
  target_include_directories(desslam_${stage} PUBLIC $<BUILD_INTERFACE:${PROJECT_SOURCE_DIR}/src>)
  target_link_libraries(desslam_${stage} PUBLIC ${ARG_DEPS})
endfunction()

# desslam_test_timeout(<out var> <seconds>): a test's timeout times DESSLAM_TEST_TIMEOUT_SCALE
# (sanitizer builds run tests several times slower).
function(desslam_test_timeout out seconds)
  if(NOT DESSLAM_TEST_TIMEOUT_SCALE)
    set(DESSLAM_TEST_TIMEOUT_SCALE 1)
  endif()
  math(EXPR scaled "${seconds} * ${DESSLAM_TEST_TIMEOUT_SCALE}")
  set(${out} ${scaled} PARENT_SCOPE)
endfunction()

# desslam_add_test(<name> SOURCES ... [DEPS ...] [LABELS ...] [TIMEOUT s])
#   one GoogleTest executable registered with CTest (gtest_discover_tests); TIMEOUT (default
#   600 s) is scaled by desslam_test_timeout.
#   DESSLAM_SHARED_DIR (../shared beside the project) is passed to the tests as an env var.
function(desslam_add_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR}/tests)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/tests)
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 600)
  endif()
  desslam_test_timeout(ARG_TIMEOUT ${ARG_TIMEOUT})
  # An empty LABELS value would swallow the next property name, so add it only when given.
  set(label_property "")
  if(ARG_LABELS)
    set(label_property LABELS "${ARG_LABELS}")
  endif()
  include(GoogleTest)
  gtest_discover_tests(${name}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES TIMEOUT ${ARG_TIMEOUT} ${label_property}
      ENVIRONMENT "DESSLAM_SHARED_DIR=${DESSLAM_SHARED_DIR};DESSLAM_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
    DISCOVERY_TIMEOUT 60)
endfunction()
