# cmake --install <build> --prefix <p> installs (components in brackets):
#   lib/libdesslam.so.<version> [runtime] and its .so link [development]
#   bin/desslam [runtime]
#   share/desslam/vocab/*.bin, share/desslam/config/*.yaml [runtime]: what a run needs, found
#     relative to the library (src/core/data_location.hpp)
#   include/desslam/*.hpp [development]: the public headers only (src/ stays internal)
#   lib/cmake/desslam/desslamConfig.cmake, desslamConfigVersion.cmake, desslamTargets*.cmake
#     [development]: find_package(desslam) gives desslam::desslam
# cpack -G DEB (in the build folder) makes desslam_<version>_<arch>.deb (runtime) and
# desslam-dev_<version>_<arch>.deb (development), their Depends from dpkg-shlibdeps.
include(CMakePackageConfigHelpers)

set(DESSLAM_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/desslam)

install(TARGETS desslam_api EXPORT desslamTargets
  LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT runtime NAMELINK_COMPONENT development)
install(TARGETS desslam RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT runtime)
# Every public header (others land beside desslam.hpp as the API grows).
install(DIRECTORY ${PROJECT_SOURCE_DIR}/include/desslam DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}
  COMPONENT development FILES_MATCHING PATTERN "*.hpp")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/vocab/ DESTINATION ${CMAKE_INSTALL_DATADIR}/desslam/vocab
  COMPONENT runtime FILES_MATCHING PATTERN "*.bin" PATTERN "README.md")
install(DIRECTORY ${PROJECT_SOURCE_DIR}/config/ DESTINATION ${CMAKE_INSTALL_DATADIR}/desslam/config
  COMPONENT runtime FILES_MATCHING PATTERN "*.yaml")

install(EXPORT desslamTargets NAMESPACE desslam:: DESTINATION ${DESSLAM_CMAKE_DIR} COMPONENT development)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/desslamConfig.cmake.in
  ${PROJECT_BINARY_DIR}/desslamConfig.cmake INSTALL_DESTINATION ${DESSLAM_CMAKE_DIR}
  PATH_VARS CMAKE_INSTALL_DATADIR)
# 0.x: a minor version may change the API, so only the same major.minor is compatible.
write_basic_package_version_file(${PROJECT_BINARY_DIR}/desslamConfigVersion.cmake
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/desslamConfig.cmake ${PROJECT_BINARY_DIR}/desslamConfigVersion.cmake
  DESTINATION ${DESSLAM_CMAKE_DIR} COMPONENT development)

# Debian packages (cpack -G DEB). Only when DeS-SLAM is the top-level project: a parent project
# packages itself.
if(PROJECT_IS_TOP_LEVEL)
  set(CPACK_PACKAGE_NAME desslam)
  set(CPACK_PACKAGE_VENDOR "DeS-SLAM")
  set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "RGB-D SLAM for dynamic scenes (library, program and data)")
  set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
  set(CPACK_PACKAGE_CONTACT "DeS-SLAM maintainers <desslam@localhost>")
  set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
  set(CPACK_GENERATOR DEB)
  set(CPACK_DEB_COMPONENT_INSTALL ON)
  set(CPACK_COMPONENTS_ALL runtime development)
  set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
  set(CPACK_DEBIAN_PACKAGE_SECTION science)
  # Depends from dpkg-shlibdeps: the Debian packages of the shared libraries the files link.
  set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME desslam)
  set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_NAME desslam-dev)
  # The Python module (dist-packages/desslam) takes numpy arrays; dpkg-shlibdeps cannot see that.
  # A recommendation: the program and the C++ library work without Python.
  set(CPACK_DEBIAN_RUNTIME_PACKAGE_RECOMMENDS "python3 (>= 3.11), python3-numpy")
  set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_SECTION libdevel)
  # The public header includes Eigen and OpenCV core; desslamConfig.cmake finds their CMake files.
  set(CPACK_DEBIAN_DEVELOPMENT_PACKAGE_DEPENDS "desslam (= ${PROJECT_VERSION}), libeigen3-dev, libopencv-dev")
  set(CPACK_COMPONENT_RUNTIME_DESCRIPTION "DeS-SLAM RGB-D SLAM: libdesslam, the desslam program, vocabulary and camera presets")
  set(CPACK_COMPONENT_DEVELOPMENT_DESCRIPTION "DeS-SLAM development files: public headers and CMake package")
  include(CPack)
endif()
