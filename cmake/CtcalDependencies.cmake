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
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs calib3d aruco)
find_package(apriltag CONFIG REQUIRED)
if(NOT TARGET apriltag::apriltag OR NOT TARGET apriltag::apriltag-utils)
  message(FATAL_ERROR "apriltag found without its apriltag::apriltag/apriltag-utils targets")
endif()
find_package(Boost REQUIRED COMPONENTS program_options)
find_package(yaml-cpp REQUIRED)
find_package(PkgConfig REQUIRED)
pkg_check_modules(CAIRO REQUIRED IMPORTED_TARGET cairo)
find_package(Threads REQUIRED)

# mrcal ships neither a CMake config nor a .pc file.
find_library(MRCAL_LIBRARY NAMES mrcal)
find_path(MRCAL_INCLUDE_DIR NAMES mrcal.h PATH_SUFFIXES mrcal)
if(NOT MRCAL_LIBRARY OR NOT MRCAL_INCLUDE_DIR)
  message(FATAL_ERROR "mrcal not found: install Debian's libmrcal-dev (make deps)")
endif()
add_library(ctcal_mrcal INTERFACE)
target_link_libraries(ctcal_mrcal INTERFACE ${MRCAL_LIBRARY})
target_include_directories(ctcal_mrcal SYSTEM INTERFACE ${MRCAL_INCLUDE_DIR})
add_library(ctcal::mrcal ALIAS ctcal_mrcal)

if(CTCAL_BUILD_TESTS)
  find_package(GTest REQUIRED)
endif()
if(CTCAL_BUILD_BENCH)
  find_package(benchmark REQUIRED)
endif()
