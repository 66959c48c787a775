# Smoke test of `voxcap-bench silhouettes` (voxcap bench forwards only edge and host): one small camera frame of hw/sim's tpose; checks the
# documented keys (README.md) and that the figures are shares in [0, 1] with the body mostly kept; then the
# same with --nodes 3 (the merged hull of a 3-node rig against the true occupancy).
execute_process(
  COMMAND ${VOXCAP_BENCH} silhouettes --motion tpose --room camouflage --frames 1 --cameras 0 --size 320x240
          --bg-frames 8 --json
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "voxcap-bench silhouettes failed (${rc}): ${err}\n${out}")
endif()
foreach(key width height bg_frames cleanup_radius_px shadow_texture_k shadow_flat_margin)
  string(JSON type ERROR_VARIABLE jerr TYPE "${out}" ${key})
  if(jerr OR NOT type STREQUAL "NUMBER")
    message(FATAL_ERROR "key '${key}' missing or not a number (${type} ${jerr}):\n${out}")
  endif()
endforeach()
string(JSON room ERROR_VARIABLE jerr GET "${out}" room)
if(jerr OR NOT room STREQUAL "camouflage")
  message(FATAL_ERROR "key 'room' is '${room}', not the camouflage room asked for (${jerr}):\n${out}")
endif()
foreach(where "overall" "cameras;0")
  foreach(key recall precision shadow_kept band_share shadow_share hands_feet_recall "lost;within_noise"
              "lost;called_shadow" "lost;cleanup")
    string(JSON v ERROR_VARIABLE jerr GET "${out}" ${where} ${key})
    if(jerr OR v LESS 0 OR v GREATER 1)
      message(FATAL_ERROR "${where} ${key}: '${v}' is not a share (${jerr}):\n${out}")
    endif()
  endforeach()
  foreach(part head torso l_hand r_hand l_foot r_foot l_forearm r_forearm l_upper_arm r_upper_arm
               l_thigh r_thigh l_shank r_shank)
    string(JSON type ERROR_VARIABLE jerr TYPE "${out}" ${where} parts ${part} pixels)
    if(jerr OR NOT type STREQUAL "NUMBER")
      message(FATAL_ERROR "${where} parts.${part} missing:\n${out}")
    endif()
  endforeach()
endforeach()
string(JSON recall GET "${out}" overall recall)
if(recall LESS 0.9)
  message(FATAL_ERROR "the edge's mask keeps only ${recall} of the body on tpose:\n${out}")
endif()
# A bad appearance is the user's mistake: exit code 2 and the preset's name.
execute_process(COMMAND ${VOXCAP_BENCH} silhouettes --appearance nosuch --frames 1
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 2 OR NOT err MATCHES "nosuch")
  message(FATAL_ERROR "an unknown appearance gave exit ${rc}: ${err}")
endif()
execute_process(COMMAND ${VOXCAP_BENCH} silhouettes --room nosuchroom --frames 1
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 2 OR NOT err MATCHES "nosuchroom")
  message(FATAL_ERROR "an unknown room gave exit ${rc}: ${err}")
endif()
# --nodes: the merged hull of a 3-node rig carved from the edges' masks, against the true occupancy.
execute_process(
  COMMAND ${VOXCAP_BENCH} silhouettes --motion tpose --nodes 3 --frames 1 --size 320x240 --bg-frames 8 --grid 64
          --json
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "voxcap-bench silhouettes --nodes 3 failed (${rc}): ${err}\n${out}")
endif()
string(JSON ncam LENGTH "${out}" cameras)
if(NOT ncam EQUAL 6)
  message(FATAL_ERROR "--nodes 3 scored ${ncam} cameras, not the rig's 6:\n${out}")
endif()
foreach(key nodes grid frames body_voxels hull_voxels)
  string(JSON type ERROR_VARIABLE jerr TYPE "${out}" hull ${key})
  if(jerr OR NOT type STREQUAL "NUMBER")
    message(FATAL_ERROR "key 'hull.${key}' missing or not a number (${type} ${jerr}):\n${out}")
  endif()
endforeach()
string(JSON carve GET "${out}" hull carve)
if(NOT carve STREQUAL "subpixel")
  message(FATAL_ERROR "hull.carve is '${carve}', not the default subpixel:\n${out}")
endif()
foreach(key recall precision worst_hand_foot_recall)
  string(JSON v ERROR_VARIABLE jerr GET "${out}" hull ${key})
  if(jerr OR v LESS 0 OR v GREATER 1)
    message(FATAL_ERROR "hull.${key}: '${v}' is not a share (${jerr}):\n${out}")
  endif()
endforeach()
foreach(part head torso l_hand r_hand l_foot r_foot l_forearm r_forearm l_upper_arm r_upper_arm
             l_thigh r_thigh l_shank r_shank)
  string(JSON n ERROR_VARIABLE jerr GET "${out}" hull parts ${part} voxels)
  if(jerr OR NOT n GREATER 0)
    message(FATAL_ERROR "hull.parts.${part}: no voxels of the body (${jerr}):\n${out}")
  endif()
endforeach()
# The T-pose seen by 6 cameras: the hull holds nearly all of the body and not much else.
string(JSON hull_recall GET "${out}" hull recall)
string(JSON hull_precision GET "${out}" hull precision)
if(hull_recall LESS 0.97 OR hull_precision LESS 0.5)
  message(FATAL_ERROR "the merged hull of tpose: recall ${hull_recall}, precision ${hull_precision}:\n${out}")
endif()
# Usage errors: --nodes takes every camera of the rig; an unknown carve rule.
execute_process(COMMAND ${VOXCAP_BENCH} silhouettes --nodes 3 --cameras 0 --frames 1
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 2 OR NOT err MATCHES "--cameras")
  message(FATAL_ERROR "--nodes with --cameras gave exit ${rc}: ${err}")
endif()
execute_process(COMMAND ${VOXCAP_BENCH} silhouettes --nodes 3 --carve nosuchrule --frames 1
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 2 OR NOT err MATCHES "nosuchrule")
  message(FATAL_ERROR "an unknown carve rule gave exit ${rc}: ${err}")
endif()
message(STATUS "voxcap-bench silhouettes: JSON complete, recall ${recall}; merged hull recall ${hull_recall}, "
               "precision ${hull_precision}")
