# Third-party dependencies, all from Debian 12 packages (scripts/install_deps.sh).
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Ceres REQUIRED)
# The batch problems are solved with SPARSE_NORMAL_CHOLESKY on CHOLMOD: without SuiteSparse the
# calibrator would silently fall back to slower dense or Eigen-sparse solvers.
list(FIND CERES_COMPILED_COMPONENTS SuiteSparse _ceres_has_suitesparse)
if(_ceres_has_suitesparse EQUAL -1)
  message(FATAL_ERROR
    "ctcal needs Ceres built with SuiteSparse (CHOLMOD); the Ceres found at ${Ceres_DIR} has no "
    "SuiteSparse support. Install Debian's libceres-dev and libsuitesparse-dev (make deps).")
endif()
find_package(OpenCV REQUIRED COMPONENTS core imgproc calib3d aruco imgcodecs)
# What ctcal's libraries, and so the ctcal program, link: not imgcodecs, which pulls GDAL, gdcm,
# poppler, hdf5 and ~90 more shared libraries (the dynamic loader's work on them was ~0.18 s of
# every start). ctcal reads PNG and JPEG through libpng and libjpeg-turbo itself
# (targets/image_file.h); only tests and benchmarks that compare with cv::imread link
# opencv_imgcodecs.
set(CTCAL_OPENCV_LIBS opencv_core opencv_imgproc opencv_calib3d opencv_aruco)
find_package(PNG REQUIRED)
find_package(JPEG REQUIRED)
find_package(apriltag CONFIG REQUIRED)
if(NOT TARGET apriltag::apriltag OR NOT TARGET apriltag::apriltag-utils)
  message(FATAL_ERROR "apriltag found without its apriltag::apriltag/apriltag-utils targets")
endif()
find_package(Boost REQUIRED COMPONENTS program_options filesystem)
find_package(yaml-cpp REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(CAIRO REQUIRED IMPORTED_TARGET cairo)
# libdeflate (Debian libdeflate-dev): the direct PNG decoder's inflate (targets/), the report data's
# gzip and the figures' PNGs (report/).
pkg_check_modules(DEFLATE REQUIRED IMPORTED_TARGET libdeflate)
find_package(Threads REQUIRED)

# mrcal ships neither a CMake config nor a .pc file.
find_library(MRCAL_LIBRARY NAMES mrcal)
find_path(MRCAL_INCLUDE_DIR NAMES mrcal.h PATH_SUFFIXES mrcal)
if(NOT MRCAL_LIBRARY OR NOT MRCAL_INCLUDE_DIR)
  message(FATAL_ERROR "mrcal not found: install Debian's libmrcal-dev (make deps)")
endif()
# The libraries load libmrcal when a camera first needs it (sensors/src/mrcal_api.h): they get
# its headers and its soname; the tests, which call it directly as a reference, link it.
execute_process(COMMAND objdump -p ${MRCAL_LIBRARY} OUTPUT_VARIABLE MRCAL_DYNAMIC_SECTION
                RESULT_VARIABLE MRCAL_OBJDUMP_RESULT)
string(REGEX MATCH "SONAME +([^\n ]+)" MRCAL_SONAME_LINE "${MRCAL_DYNAMIC_SECTION}")
if(NOT MRCAL_OBJDUMP_RESULT EQUAL 0 OR NOT CMAKE_MATCH_1)
  message(FATAL_ERROR "cannot read the soname of ${MRCAL_LIBRARY} (objdump -p, from binutils)")
endif()
set(MRCAL_SONAME ${CMAKE_MATCH_1})
add_library(ctcal_mrcal_headers INTERFACE)
target_include_directories(ctcal_mrcal_headers SYSTEM INTERFACE ${MRCAL_INCLUDE_DIR})
target_compile_definitions(ctcal_mrcal_headers INTERFACE CTCAL_MRCAL_SONAME="${MRCAL_SONAME}")
target_link_libraries(ctcal_mrcal_headers INTERFACE ${CMAKE_DL_LIBS})
add_library(ctcal::mrcal_headers ALIAS ctcal_mrcal_headers)
add_library(ctcal_mrcal INTERFACE)
target_link_libraries(ctcal_mrcal INTERFACE ctcal_mrcal_headers ${MRCAL_LIBRARY})
add_library(ctcal::mrcal ALIAS ctcal_mrcal)

if(CTCAL_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(CTCAL_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()

# ROS bags (SPEC section 6). Debian's librosbag-storage-dev is the ROS1 bag container without the
# ROS runtime, but its .pc file requires a pluginlib.pc Debian does not ship, and bag.h includes
# the ROS 2 pluginlib/class_loader headers, each under a doubled include folder
# (/usr/include/<pkg>/<pkg>/): so the library and those folders are found one by one. The
# messages themselves are decoded by ctcal (sensors/src/ros_wire.cpp); only the serialization
# stream types come from roscpp_serialization, and ros::Header lives in cpp_common.
find_library(ROSBAG_STORAGE_LIBRARY NAMES rosbag_storage)
find_path(ROSBAG_INCLUDE_DIR NAMES rosbag/bag.h)
set(_ctcal_ros_include_dirs ${ROSBAG_INCLUDE_DIR})
foreach(_pkg pluginlib class_loader rcpputils rcutils ament_index_cpp)
  find_path(_ctcal_${_pkg}_dir NAMES ${_pkg} PATHS /usr/include/${_pkg} NO_DEFAULT_PATH)
  if(NOT _ctcal_${_pkg}_dir)
    message(FATAL_ERROR "${_pkg} headers not found (/usr/include/${_pkg}/${_pkg}): install "
                        "Debian's librosbag-storage-dev (make deps)")
  endif()
  list(APPEND _ctcal_ros_include_dirs ${_ctcal_${_pkg}_dir})
endforeach()
set(_ctcal_ros_libraries ${ROSBAG_STORAGE_LIBRARY})
foreach(_lib roscpp_serialization rostime cpp_common console_bridge class_loader)
  find_library(_ctcal_${_lib}_library NAMES ${_lib})
  if(NOT _ctcal_${_lib}_library)
    message(FATAL_ERROR "lib${_lib} not found: install Debian's librosbag-storage-dev (make deps)")
  endif()
  list(APPEND _ctcal_ros_libraries ${_ctcal_${_lib}_library})
endforeach()
if(NOT ROSBAG_STORAGE_LIBRARY OR NOT ROSBAG_INCLUDE_DIR)
  message(FATAL_ERROR "rosbag_storage not found: install Debian's librosbag-storage-dev (make deps)")
endif()
add_library(ctcal_rosbag INTERFACE)
target_link_libraries(ctcal_rosbag INTERFACE ${_ctcal_ros_libraries} Boost::filesystem)
target_include_directories(ctcal_rosbag SYSTEM INTERFACE ${_ctcal_ros_include_dirs})
add_library(ctcal::rosbag ALIAS ctcal_rosbag)
# ROS 2 bags' default storage is an sqlite3 database.
find_package(SQLite3 REQUIRED)
