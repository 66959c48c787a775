# CTest host_view_install: host/view's install rules (component host, what the voxcap .deb takes) run
# into a scratch prefix; the page must be there whole, and a binary in the prefix's bin/ must find it
# through the install layout (assets.hpp) rather than the build tree.
# -D: BUILD_DIR (host/view's build folder), WORK, PROBE (vc_view_assets_probe), BINDIR, WEBDIR (relative
# to the prefix), THREE (ON when three.js was there to install).
file(REMOVE_RECURSE ${WORK})
set(prefix ${WORK}/prefix)
execute_process(
  COMMAND ${CMAKE_COMMAND} -DCMAKE_INSTALL_PREFIX=${prefix} -DCMAKE_INSTALL_COMPONENT=host
          -P ${BUILD_DIR}/cmake_install.cmake
  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "install of host/view failed (${rc}):\n${out}")
endif()
set(want index.html app.js protocol.js style.css)
if(THREE)
  list(APPEND want lib/three.module.js lib/OrbitControls.js)
endif()
foreach(f IN LISTS want)
  if(NOT EXISTS ${prefix}/${WEBDIR}/${f})
    message(FATAL_ERROR "the install tree lacks ${WEBDIR}/${f}:\n${out}")
  endif()
endforeach()
file(MAKE_DIRECTORY ${prefix}/${BINDIR})
file(COPY ${PROBE} DESTINATION ${prefix}/${BINDIR})
get_filename_component(probe_name ${PROBE} NAME)
execute_process(COMMAND ${prefix}/${BINDIR}/${probe_name} RESULT_VARIABLE rc OUTPUT_VARIABLE found
                ERROR_VARIABLE err OUTPUT_STRIP_TRAILING_WHITESPACE)
file(REAL_PATH ${prefix}/${WEBDIR} expected)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the installed probe found no page (${rc}): ${err}")
endif()
file(REAL_PATH ${found} found_real)
if(NOT found_real STREQUAL expected)
  message(FATAL_ERROR "the installed probe serves ${found}, not the install tree's ${expected}")
endif()
message(STATUS "host_view_install: ${want} in ${prefix}/${WEBDIR}, found from ${BINDIR}/")
