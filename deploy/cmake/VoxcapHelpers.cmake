# Shared build settings and helpers for every folder.
include_guard(GLOBAL)
include(GoogleTest)

add_library(vc_warnings INTERFACE)
target_compile_options(vc_warnings INTERFACE
  -Wall -Wextra -Wshadow -Wformat=2 -Wundef
  $<$<COMPILE_LANGUAGE:C>:-Wstrict-prototypes -Wmissing-prototypes>
  $<$<BOOL:${VOXCAP_WERROR}>:-Werror>)

if(VOXCAP_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(VOXCAP_LTO)
  set(CMAKE_INTERPROCEDURAL_OPTIMIZATION ON)
endif()

# vc_test(NAME <name> SOURCES <files...> LIBS <targets...> LABELS <labels...> [TIMEOUT <s>] [SERIAL])
# A GoogleTest binary whose cases are registered with CTest one by one, labelled. SERIAL: its cases
# run alone (whole-rig tests that need both cores).
function(vc_test)
  cmake_parse_arguments(T "SERIAL" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 300)
  endif()
  add_executable(${T_NAME} ${T_SOURCES})
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest GTest::gmock GTest::gtest_main vc_warnings)
  target_compile_definitions(${T_NAME} PRIVATE
    VOXCAP_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    VOXCAP_BINARY_DIR="${PROJECT_BINARY_DIR}"
    VOXCAP_SHARED_DIR="${PROJECT_SOURCE_DIR}/../shared")
  gtest_discover_tests(${T_NAME}
    DISCOVERY_MODE PRE_TEST
    PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT} RUN_SERIAL ${T_SERIAL}
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
endfunction()

# vc_find_opencv(<modules...>): OpenCV 4 for the given modules, as the targets opencv_<module>.
# OpenCV's CMake package (OpenCVConfig.cmake) comes with Debian's libopencv-dev, which is not
# multiarch-installable. A cross build against the arm64 packages has, instead, per module: the
# -dev package (core, imgproc, video: headers and libopencv_<m>.so), or only the runtime library
# (calib3d: libopencv_<m>.so.406, whose -dev package cannot be installed beside the amd64 host's;
# its headers are the amd64 -dev package's, the same version), or nothing (imgcodecs: its arm64
# runtime conflicts with the host's GDAL). There each module found becomes an imported target of its
# own (the names the package file defines); a missing one is left undefined, and its users test
# TARGET opencv_<m>.
macro(vc_find_opencv)
  find_package(OpenCV 4 QUIET COMPONENTS ${ARGN})
  if(NOT OpenCV_FOUND)
    find_path(VC_OPENCV_INCLUDE_DIR opencv2/core.hpp PATH_SUFFIXES opencv4 REQUIRED)
    set(_vc_cv_inc ${VC_OPENCV_INCLUDE_DIR})
    if(EXISTS /usr/include/${CMAKE_LIBRARY_ARCHITECTURE}/opencv4)
      list(APPEND _vc_cv_inc /usr/include/${CMAKE_LIBRARY_ARCHITECTURE}/opencv4) # cvconfig.h
    endif()
    set(_vc_cv_found)
    foreach(_vc_m ${ARGN})
      if(NOT TARGET opencv_${_vc_m})
        find_library(VC_OPENCV_${_vc_m}_LIBRARY NAMES opencv_${_vc_m} libopencv_${_vc_m}.so.406)
        if(VC_OPENCV_${_vc_m}_LIBRARY)
          add_library(opencv_${_vc_m} SHARED IMPORTED GLOBAL)
          set_target_properties(opencv_${_vc_m} PROPERTIES
            IMPORTED_LOCATION ${VC_OPENCV_${_vc_m}_LIBRARY}
            INTERFACE_INCLUDE_DIRECTORIES "${_vc_cv_inc}")
          if(NOT _vc_m STREQUAL "core")
            set_property(TARGET opencv_${_vc_m} APPEND PROPERTY INTERFACE_LINK_LIBRARIES opencv_core)
          endif()
          list(APPEND _vc_cv_found ${_vc_m})
        endif()
      endif()
    endforeach()
    if(NOT TARGET opencv_core)
      message(FATAL_ERROR "OpenCV: neither its CMake package nor libopencv_core found")
    endif()
    message(STATUS "OpenCV: no CMake package (cross build); imported ${_vc_cv_found} from ${_vc_cv_inc}")
  endif()
endmacro()

# vc_find_libcamera(): PkgConfig::LIBCAMERA (libcamera >= 0.3). Debian's libcamera-dev is not
# multiarch-installable (its arm64 and amd64 packages replace each other); a cross build has the arm64
# runtime libraries (libcamera0.3:arm64) and the amd64 -dev package's headers, which are the same for
# every architecture. There the target is made from those (the same flags libcamera.pc gives).
macro(vc_find_libcamera)
  if(CMAKE_CROSSCOMPILING)
    pkg_check_modules(LIBCAMERA QUIET IMPORTED_TARGET libcamera>=0.3)
  else()
    pkg_check_modules(LIBCAMERA REQUIRED IMPORTED_TARGET libcamera>=0.3)
  endif()
  if(NOT TARGET PkgConfig::LIBCAMERA)
    find_path(VC_LIBCAMERA_INCLUDE_DIR libcamera/camera_manager.h PATH_SUFFIXES libcamera REQUIRED)
    find_library(VC_LIBCAMERA_LIBRARY NAMES camera libcamera.so.0.3 REQUIRED)
    find_library(VC_LIBCAMERA_BASE_LIBRARY NAMES camera-base libcamera-base.so.0.3 REQUIRED)
    add_library(PkgConfig::LIBCAMERA INTERFACE IMPORTED GLOBAL)
    set_target_properties(PkgConfig::LIBCAMERA PROPERTIES
      INTERFACE_INCLUDE_DIRECTORIES ${VC_LIBCAMERA_INCLUDE_DIR}
      INTERFACE_LINK_LIBRARIES "${VC_LIBCAMERA_LIBRARY};${VC_LIBCAMERA_BASE_LIBRARY}")
    message(STATUS "libcamera: no arm64 libcamera.pc (cross build); ${VC_LIBCAMERA_LIBRARY} with ${VC_LIBCAMERA_INCLUDE_DIR}")
  endif()
endmacro()
