# Finds Debian's ROS 1 rosbag storage library (librosbag-storage-dev, with libroscpp-core-dev)
# and defines the imported target RosbagStorage::RosbagStorage.
#
# Not through the package's own files: on bookworm its pkg-config file requires a "pluginlib.pc"
# that does not exist, and its CMake config find_package()s pluginlib, whose ament_cmake set-up
# runs python3 with ament_package (Debian's /usr/bin/python3 only, not another python3 on PATH)
# and defines ament macros in the including project. Only headers and libraries are needed:
# rosbag/bag.h includes pluginlib/class_loader.hpp, which (ROS 2 layout) lives one folder deeper,
# and includes class_loader, rcutils, rcpputils and ament_index_cpp headers laid out the same way.
find_path(RosbagStorage_INCLUDE_DIR rosbag/bag.h)
find_path(RosbagStorage_PLUGINLIB_INCLUDE_DIR pluginlib/class_loader.hpp PATH_SUFFIXES pluginlib)
set(_rosbag_ros2_include_dirs "")
foreach(_pkg class_loader rcutils rcpputils ament_index_cpp)
  find_path(RosbagStorage_${_pkg}_INCLUDE_DIR ${_pkg} NO_DEFAULT_PATH
            PATHS /usr/include/${_pkg} ${CMAKE_PREFIX_PATH}/include/${_pkg})
  if(RosbagStorage_${_pkg}_INCLUDE_DIR)
    list(APPEND _rosbag_ros2_include_dirs ${RosbagStorage_${_pkg}_INCLUDE_DIR})
  endif()
endforeach()
set(_rosbag_libraries "")
foreach(_lib rosbag_storage rostime roscpp_serialization cpp_common console_bridge boost_filesystem)
  find_library(RosbagStorage_${_lib}_LIBRARY ${_lib})
  list(APPEND _rosbag_libraries ${RosbagStorage_${_lib}_LIBRARY})
endforeach()

include(FindPackageHandleStandardArgs)
find_package_handle_standard_args(RosbagStorage
  REQUIRED_VARS RosbagStorage_INCLUDE_DIR RosbagStorage_PLUGINLIB_INCLUDE_DIR RosbagStorage_rosbag_storage_LIBRARY
                RosbagStorage_rostime_LIBRARY RosbagStorage_roscpp_serialization_LIBRARY
                RosbagStorage_cpp_common_LIBRARY RosbagStorage_console_bridge_LIBRARY
                RosbagStorage_boost_filesystem_LIBRARY
  REASON_FAILURE_MESSAGE "install librosbag-storage-dev and libroscpp-core-dev (scripts/install-and-build.sh)")

if(RosbagStorage_FOUND AND NOT TARGET RosbagStorage::RosbagStorage)
  add_library(RosbagStorage::RosbagStorage INTERFACE IMPORTED)
  # SYSTEM: warnings in these headers are not ours.
  set_target_properties(RosbagStorage::RosbagStorage PROPERTIES
    INTERFACE_SYSTEM_INCLUDE_DIRECTORIES "${RosbagStorage_INCLUDE_DIR};${RosbagStorage_PLUGINLIB_INCLUDE_DIR};${_rosbag_ros2_include_dirs}"
    INTERFACE_INCLUDE_DIRECTORIES "${RosbagStorage_INCLUDE_DIR};${RosbagStorage_PLUGINLIB_INCLUDE_DIR};${_rosbag_ros2_include_dirs}"
    INTERFACE_LINK_LIBRARIES "${_rosbag_libraries}")
endif()
