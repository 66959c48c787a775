# Test of the layer check (VoxcapLayers.cmake): it must pass a graph whose arrows point down and catch a
# planted upward arrow, a library or program without a layer and a malformed table -- first on fake
# graphs given to vc_layers_check(), then on the real link graph of a small project configured here,
# where the upward arrow is planted as a PRIVATE link ($<LINK_ONLY:...>), from another folder (::@
# markers) and inside a generator expression.
# -D: WORK (a build-tree directory), GENERATOR, C_COMPILER (for the small project).
cmake_minimum_required(VERSION 3.25)
include(${CMAKE_CURRENT_LIST_DIR}/VoxcapLayers.cmake)

set(failures 0)
function(expect what errors)
  cmake_parse_arguments(E "" "COUNT" "MATCHES" ${ARGN})
  list(LENGTH errors n)
  if(NOT n EQUAL E_COUNT)
    message(SEND_ERROR "${what}: ${n} problems, expected ${E_COUNT}:\n${errors}")
    return()
  endif()
  foreach(re IN LISTS E_MATCHES)
    if(NOT errors MATCHES "${re}")
      message(SEND_ERROR "${what}: no problem matches '${re}':\n${errors}")
    endif()
  endforeach()
  message(STATUS "ok: ${what}")
endfunction()

# ---- fake graphs, the real table -------------------------------------------------------------------
set(libs vc_warnings vc_proto vc_proto_json vc_rig vc_sim vc_edge_core vc_host_config vc_host_record)
set(progs voxcap voxcap-bench vc_rig_test)
set(down vc_proto_json>vc_proto vc_rig>vc_proto vc_sim>vc_rig vc_host_record>vc_proto
         vc_host_config>vc_rig vc_proto>vc_warnings voxcap>vc_host_record voxcap-bench>voxcap
         vc_rig_test>vc_rig vc_rig_test>vc_host_record)
vc_layers_check(errors LIBRARIES ${libs} PROGRAMS ${progs} EDGES ${down})
expect("arrows that point down (and a test linking anything) pass" "${errors}" COUNT 0)

vc_layers_check(errors LIBRARIES ${libs} PROGRAMS ${progs} EDGES ${down} vc_proto>vc_host_record)
expect("a planted arrow up is named" "${errors}" COUNT 1
  MATCHES "vc_proto \\(proto\\) -> vc_host_record \\(host/record\\): links a layer above its own")

vc_layers_check(errors LIBRARIES ${libs} PROGRAMS ${progs} EDGES ${down} voxcap>vc_bench_edge)
expect("an app linking tests/bench is named" "${errors}" COUNT 1
  MATCHES "voxcap \\(apps\\) -> vc_bench_edge \\(tests/bench\\)")

vc_layers_check(errors LIBRARIES ${libs} PROGRAMS ${progs} EDGES ${down} vc_edge_core>vc_sim vc_rig>vc_body)
expect("two arrows up, two problems" "${errors}" COUNT 2
  MATCHES "vc_edge_core \\(edge/core\\) -> vc_sim \\(hw/sim\\)" "vc_rig \\(hw/rig\\) -> vc_body \\(hw/body\\)")

vc_layers_check(errors LIBRARIES ${libs} vc_edge_new PROGRAMS ${progs} voxcap-view EDGES ${down})
expect("a library and a program without a layer are errors" "${errors}" COUNT 2
  MATCHES "library vc_edge_new is in no layer: add it to VC_LAYERS in [^ ]*VoxcapLayers.cmake"
          "program voxcap-view is in no layer")

vc_layers_check(errors LAYERS "a: vc_a" "b: vc_b vc_a" "no colon here" LIBRARIES vc_a vc_b EDGES vc_a>vc_b)
expect("a malformed table is reported" "${errors}" COUNT 2
  MATCHES "vc_a is in two layers, a and b" "'no colon here' is not")

# Peers in one layer may link each other.
vc_layers_check(errors LIBRARIES vc_edge_camera vc_edge_camera_sim EDGES vc_edge_camera>vc_edge_camera_sim)
expect("a link within a layer passes" "${errors}" COUNT 0)

# ---- the real link graph of a small configured project ---------------------------------------------
set(fixture ${WORK}/fixture)
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${fixture}/host)
file(WRITE ${fixture}/x.c "int vc_x(void);\nint vc_x(void) { return 0; }\n")
file(WRITE ${fixture}/CMakeLists.txt "cmake_minimum_required(VERSION 3.25)
project(layers_fixture LANGUAGES C)
include(${CMAKE_CURRENT_LIST_DIR}/VoxcapLayers.cmake)
add_library(vc_warnings INTERFACE)
add_library(vc_proto STATIC x.c)
target_link_libraries(vc_proto PRIVATE vc_warnings)
add_library(vc_rig STATIC x.c)
target_link_libraries(vc_rig PUBLIC vc_proto PRIVATE m)
add_subdirectory(host)
add_executable(vc_rig_test x.c)
target_link_libraries(vc_rig_test PRIVATE vc_host_record vc_rig)
if(PLANT STREQUAL \"private\")
  target_link_libraries(vc_rig PRIVATE vc_host_record)
elseif(PLANT STREQUAL \"genex\")
  target_link_libraries(vc_proto INTERFACE $<$<BOOL:1>:vc_host_record>)
elseif(PLANT STREQUAL \"nolayer\")
  add_library(vc_edge_new STATIC x.c)
endif()
cmake_language(DEFER CALL vc_layers_check_project)
")
file(WRITE ${fixture}/host/CMakeLists.txt "add_library(vc_host_record STATIC ../x.c)
target_link_libraries(vc_host_record PUBLIC vc_rig)
add_library(vc_host_session INTERFACE)
target_link_libraries(vc_host_session INTERFACE vc_proto)
if(PLANT STREQUAL \"other-folder\")
  target_link_libraries(vc_proto PRIVATE vc_host_session)  # from this folder: vc_host_session::@(...)
endif()
")

function(configure plant expect_ok regex)
  set(build ${WORK}/build-${plant})
  execute_process(
    COMMAND ${CMAKE_COMMAND} -S ${fixture} -B ${build} -G ${GENERATOR} -DCMAKE_C_COMPILER=${C_COMPILER}
            -DPLANT=${plant}
    OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  string(REGEX REPLACE "\n +" " " text "${out}${err}")  # CMake wraps long messages
  if(expect_ok AND NOT rc EQUAL 0)
    message(SEND_ERROR "fixture, ${plant}: configuring failed:\n${out}${err}")
  elseif(NOT expect_ok AND rc EQUAL 0)
    message(SEND_ERROR "fixture, ${plant}: configuring passed; the check missed it:\n${out}")
  elseif(NOT text MATCHES "${regex}")
    message(SEND_ERROR "fixture, ${plant}: output does not match '${regex}':\n${out}${err}")
  else()
    message(STATUS "ok: fixture, ${plant}")
  endif()
endfunction()

configure(none TRUE "layer check: 5 libraries and the programs in VC_LAYERS; none of the [0-9]+ arrows points up")
configure(private FALSE "vc_rig \\(hw/rig\\) -> vc_host_record \\(host/record\\): links a layer above its own")
configure(genex FALSE "vc_proto \\(proto\\) -> vc_host_record \\(host/record\\)")
configure(other-folder FALSE "vc_proto \\(proto\\) -> vc_host_session \\(host/session\\)")
configure(nolayer FALSE "library vc_edge_new is in no layer")
file(REMOVE_RECURSE ${WORK})
