# The layer stack of the build, in one place, and the check that every arrow of the link graph points down.
#
# VC_LAYERS lists the layers bottom to top, one line each: "<layer>: <targets...>". A target may link
# targets of its own layer and of the layers below it, never one above. The check runs at the end of
# configuring (vc_layers_check_project(), called deferred from the top CMakeLists.txt) on the real graph:
# the LINK_LIBRARIES and INTERFACE_LINK_LIBRARIES of every library of the project and of every program in
# the table. It fails configuring with a message naming each offending arrow. Every library named vc_*
# and every program named voxcap* must have a layer: a new one is an error until it is added here.
# Other programs (tests, benchmarks, fuzzers, tools) are leaves that nothing links; they are not checked.
#
# The order follows the folders (proto -> hw -> edge -> host -> apps -> tests/bench), except that
# edge/core sits right above the header-only structs, below proto: it may link nothing else of ours.
#
# To add a library: put its name on its folder's line, or add a line for a new folder where it sits in
# the stack. Names of targets that do not exist (yet) are allowed, so branches can land in any order.
include_guard(GLOBAL)

set(VC_LAYERS
  "build: vc_warnings"                  # warning flags: an interface every target links
  "proto/headers: vc_proto_models"      # header-only C structs (camera, voxel grid) shared by all
  "edge/core: vc_edge_core"             # the edge's hot kernels: C, depends on nothing but headers
  "proto: vc_proto"                     # the wire protocol, C11
  "proto/c++: vc_proto_cxx vc_proto_json vc_proto_testing"
  "proto/tools: vc_proto_vectorgen"
  "hw/rig: vc_rig"                      # cameras, calibration, voxel grid
  "hw/body: vc_body vc_body_cv vc_body_test_clips"                    # joints, skeleton, BVH
  "hw/sim: vc_sim"                      # the virtual rig's renderer
  "edge/clock: vc_edge_clock"
  "edge/camera: vc_edge_camera_c vc_edge_camera_cxx vc_edge_camera_sim vc_edge_camera_nosim vc_edge_camera"
  "edge/trigger: vc_edge_trigger"
  "edge/segment: vc_edge_segment"       # GVD segmentation (OpenCV only)
  "edge/track: vc_edge_track"           # head, hands, feet tracking (C++17 over OpenCV)
  "edge/daemon: vc_edge_daemon vc_edge_config"  # vc_edge_config: edge.toml's reader (host/deploy too)
  "host/base: vc_host_base"             # the host's logger and clock, below every host library
  "host/hil: vc_host_hil vc_host_hil_camera"  # hil figures from timestamp streams; its cameras (edge/camera or absent)
  "host/calib: vc_host_calib"           # calib import, offline carving (hw/rig, edge/core)
  "host/calibrate: vc_host_calibrate"   # rig calibration from board views (OpenCV aruco, Ceres)
  "host/config: vc_host_config"         # host/: in host/README.md's order
  "host/trigger: vc_host_trigger"
  "host/session: vc_host_session"
  "host/pipeline: vc_host_pipeline"     # the stage lifecycle; the stages in the layers above link it
  "host/assemble: vc_host_assemble"
  "host/triangulate: vc_host_triangulate vc_host_triangulate_testing"  # features in 3D, the "triangulate" stage
  "host/fit: vc_host_fit vc_host_fit_testing"  # the two-layer skeleton, the "fit" stage
  "host/record: vc_host_record vc_host_record_testing"
  "host/export: vc_host_export"         # fitted poses -> BVH and joints.csv (hw/body's standard humanoid)
  "host/stream: vc_host_stream vc_host_stream_testing"  # the live pose stream out: VMC over OSC/UDP (liblo)
  "host/aggregator: vc_host_aggregator"
  "host/emulated: vc_host_emulated"
  "host/hil/run: vc_host_hil_run"       # voxcap hil's tests: devices, aggregator, emulated rig -> figures
  "host/deploy: vc_host_deploy"         # voxcap deploy: boards over ssh, flash-config (edge.toml via the edge's reader)
  "host/view: vc_host_view"             # the live viewer: server, view stage, record switch, replay
  "apps: voxcap voxcap-host voxcap-edge voxcap-edge-nosim"
  "tests/bench: vc_bench_edge vc_bench_host voxcap-bench")

set(VC_LAYERS_FILE ${CMAKE_CURRENT_LIST_FILE})

# vc_layers_check(<out-var> [LAYERS <lines...>] [LIBRARIES <names...>] [PROGRAMS <names...>]
#                 [EDGES <from>to...>])
# The check on a given graph, without looking at any target: <out-var> receives the list of problems
# (empty when every arrow points down). LAYERS defaults to VC_LAYERS. LIBRARIES and PROGRAMS are the
# graph's libraries and programs (for the "in no layer" errors); EDGES its arrows, "from>to".
function(vc_layers_check out)
  cmake_parse_arguments(A "" "" "LAYERS;LIBRARIES;PROGRAMS;EDGES" ${ARGN})
  if(NOT DEFINED A_LAYERS)
    set(A_LAYERS ${VC_LAYERS})
  endif()
  set(errors)
  set(rank 0)
  foreach(line IN LISTS A_LAYERS)
    if(NOT line MATCHES "^([^: ]+): *(.*)$")
      list(APPEND errors "layer table: '${line}' is not '<layer>: <targets...>'")
      continue()
    endif()
    set(layer ${CMAKE_MATCH_1})
    string(REGEX REPLACE " +" ";" names "${CMAKE_MATCH_2}")
    list(REMOVE_ITEM names "")
    foreach(name IN LISTS names)
      if(DEFINED _vc_layer_${name})
        list(APPEND errors "layer table: ${name} is in two layers, ${_vc_layer_${name}} and ${layer}")
      endif()
      set(_vc_layer_${name} ${layer})
      set(_vc_rank_${name} ${rank})
    endforeach()
    math(EXPR rank "${rank} + 1")
  endforeach()

  foreach(lib IN LISTS A_LIBRARIES)
    if(lib MATCHES "^vc_" AND NOT DEFINED _vc_rank_${lib})
      list(APPEND errors "library ${lib} is in no layer: add it to VC_LAYERS in ${VC_LAYERS_FILE} (on its \
folder's line, or on a new line where it sits in the stack)")
    endif()
  endforeach()
  foreach(prog IN LISTS A_PROGRAMS)
    if(prog MATCHES "^voxcap" AND NOT DEFINED _vc_rank_${prog})
      list(APPEND errors "program ${prog} is in no layer: add it to VC_LAYERS in ${VC_LAYERS_FILE} (apps)")
    endif()
  endforeach()

  foreach(edge IN LISTS A_EDGES)
    if(NOT edge MATCHES "^([^>]+)>([^>]+)$")
      list(APPEND errors "bad arrow '${edge}' (expected from>to)")
      continue()
    endif()
    set(from ${CMAKE_MATCH_1})
    set(to ${CMAKE_MATCH_2})
    # Leaves (tests, tools) and targets without a layer (reported above) have no rank to compare.
    if(NOT DEFINED _vc_rank_${from} OR NOT DEFINED _vc_rank_${to})
      continue()
    endif()
    if(_vc_rank_${to} GREATER _vc_rank_${from})
      list(APPEND errors "${from} (${_vc_layer_${from}}) -> ${to} (${_vc_layer_${to}}): links a layer \
above its own, and arrows must point down (the stack: VC_LAYERS in ${VC_LAYERS_FILE})")
    endif()
  endforeach()
  set(${out} "${errors}" PARENT_SCOPE)
endfunction()

# Every build-system target defined in <dir> and below.
function(_vc_layers_targets dir out)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(sub IN LISTS subdirs)
    _vc_layers_targets(${sub} more)
    list(APPEND targets ${more})
  endforeach()
  set(${out} ${targets} PARENT_SCOPE)
endfunction()

# vc_layers_check_project(): the check on this project's real link graph; a FATAL_ERROR naming every
# offending arrow. Call it once every target exists (deferred to the end of the top directory).
function(vc_layers_check_project)
  _vc_layers_targets(${PROJECT_SOURCE_DIR} targets)
  set(libraries)
  set(programs)
  set(edges)
  foreach(t IN LISTS targets)
    get_target_property(type ${t} TYPE)
    if(type STREQUAL "EXECUTABLE")
      list(APPEND programs ${t})
    elseif(type MATCHES "LIBRARY$")
      list(APPEND libraries ${t})
    else()
      continue()  # custom targets
    endif()
    set(links)
    if(NOT type STREQUAL "INTERFACE_LIBRARY")
      get_target_property(direct ${t} LINK_LIBRARIES)
      if(direct)
        list(APPEND links ${direct})
      endif()
    endif()
    get_target_property(iface ${t} INTERFACE_LINK_LIBRARIES)
    if(iface)
      list(APPEND links ${iface})
    endif()
    # Items may be generator expressions ($<LINK_ONLY:x>, $<$<BOOL:..>:x>) or carry a directory marker
    # (x::@(0x...)) when linked from another folder: every word that names one of our targets counts.
    foreach(item IN LISTS links)
      string(REGEX MATCHALL "[A-Za-z0-9_+.-]+" words "${item}")
      foreach(w IN LISTS words)
        if(TARGET ${w} AND w IN_LIST targets AND NOT w STREQUAL t)
          list(APPEND edges "${t}>${w}")
        endif()
      endforeach()
    endforeach()
  endforeach()
  list(REMOVE_DUPLICATES edges)
  vc_layers_check(errors LIBRARIES ${libraries} PROGRAMS ${programs} EDGES ${edges})
  if(errors)
    list(JOIN errors "\n  " text)
    message(FATAL_ERROR "layer check: an arrow points up, or a target has no layer:\n  ${text}")
  endif()
  list(LENGTH libraries n_libraries)
  list(LENGTH edges n_edges)
  message(STATUS "layer check: ${n_libraries} libraries and the programs in VC_LAYERS; none of the \
${n_edges} arrows points up")
endfunction()
