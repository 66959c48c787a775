# The accuracy sweep of issue #10, offline: `voxcap-bench silhouettes --nodes N --json` (the edge's
# real kernels on hw/sim's frames: subtraction, clean-up, each node's carve, the merge) over the matrix
# of motions, node counts, appearances and rooms. One table (stdout, and TABLE when given) with each
# cell's merged-hull body recall, its worst hand and foot, the hull's precision (voxels within one voxel
# of the body), the masks' recall, precision and floor shadow kept, and the hull's recall per part
# group. No real-time rig, so the figures do not depend on the machine's load (the live rig's are
# `rig_accuracy.cmake`'s). The whole matrix is 144 cells of ~3-6 s at 640x480 / 128^3:
#
#   cmake -DVOXCAP_BENCH=build/release/bin/voxcap-bench -P tests/bench/hull_sweep.cmake
#   cmake -DVOXCAP_BENCH=... -DMOTIONS="wave;walk" -DNODES=3 -DAPPEARANCES=dark -DROOMS=camouflage \
#         -DFRAMES=10 -DEVERY=59 -DGRID=128 -DSIZE=640x480 -DCARVE=subpixel -DARGS="--shadow-texture-k;1.5;--shadow-flat-margin;0.2" \
#         -DJSON_DIR=/tmp/sweep -DTABLE=sweep.txt -P tests/bench/hull_sweep.cmake
#
# Defaults: the whole matrix (wave walk squat turn arms-close cross; 3 and 4 nodes; every appearance
# preset; both rooms), 10 frames 59 apart from the end of the lead-in (about 10 s of each motion), the
# emulated rig's 20 background frames, 128^3, 640x480, the subpixel carve rule (the host's default).
# A cell whose run fails is a row saying so; the script goes on and exits 1 at the end.
cmake_minimum_required(VERSION 3.19)  # string(JSON)

if(NOT VOXCAP_BENCH)
  message(FATAL_ERROR "hull_sweep: -DVOXCAP_BENCH=path/to/voxcap-bench is required")
endif()
foreach(pair "MOTIONS;wave;walk;squat;turn;arms-close;cross" "NODES;3;4"
             "APPEARANCES;default;pale;olive;brown;dark;beige" "ROOMS;default;camouflage" "FRAMES;10"
             "EVERY;59" "BG_FRAMES;20" "GRID;128" "SIZE;640x480" "CARVE;subpixel")
  list(POP_FRONT pair var)
  if(NOT DEFINED ${var})
    set(${var} "${pair}")
  endif()
endforeach()
if(JSON_DIR)
  file(MAKE_DIRECTORY "${JSON_DIR}")
endif()

include(${CMAKE_CURRENT_LIST_DIR}/table_format.cmake)  # percent(), pad()

set(parts head torso l_upper_arm r_upper_arm l_forearm r_forearm l_hand r_hand l_thigh r_thigh l_shank r_shank
          l_foot r_foot)
set(part_heads head torso luarm ruarm lfore rfore lhand rhand lthig rthig lshnk rshnk lfoot rfoot)
set(header "motion     nodes appearance room       |  recall  hand_min  foot_min  precision | sil_recall sil_prec shadow_kept |")
foreach(h IN LISTS part_heads)
  pad("${h}" 6 h)
  string(APPEND header "${h}")
endforeach()
set(lines "${header}")
execute_process(COMMAND ${CMAKE_COMMAND} -E echo "${header}")
set(failed 0)
foreach(motion IN LISTS MOTIONS)
  foreach(nodes IN LISTS NODES)
    foreach(appearance IN LISTS APPEARANCES)
      foreach(room IN LISTS ROOMS)
        execute_process(
          COMMAND ${VOXCAP_BENCH} silhouettes --json --nodes ${nodes} --motion ${motion} --appearance ${appearance}
                  --room ${room} --frames ${FRAMES} --every ${EVERY} --bg-frames ${BG_FRAMES} --grid ${GRID}
                  --size ${SIZE} --carve ${CARVE} ${ARGS}
          OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
        string(SUBSTRING "${motion}          " 0 10 c_motion)
        string(SUBSTRING "${appearance}          " 0 10 c_app)
        string(SUBSTRING "${room}          " 0 10 c_room)
        set(row "${c_motion} ${nodes}     ${c_app} ${c_room} |")
        if(NOT rc EQUAL 0)
          string(REPLACE "\n" " " err "${err}")
          string(APPEND row " failed (exit ${rc}): ${err}")
          set(failed 1)
        else()
          if(JSON_DIR)
            file(WRITE "${JSON_DIR}/${motion}-${nodes}-${appearance}-${room}.json" "${out}")
          endif()
          string(JSON recall GET "${out}" hull recall)
          string(JSON precision GET "${out}" hull precision)
          set(hand_min 2)
          set(foot_min 2)
          set(part_cols "")
          foreach(p IN LISTS parts)
            string(JSON v GET "${out}" hull parts ${p} recall)
            percent("${v}" pv)
            pad("${pv}" 6 pv)
            string(APPEND part_cols "${pv}")
            if(p MATCHES "hand$" AND v LESS hand_min)
              set(hand_min "${v}")
            endif()
            if(p MATCHES "foot$" AND v LESS foot_min)
              set(foot_min "${v}")
            endif()
          endforeach()
          string(JSON sr GET "${out}" overall recall)
          string(JSON sp GET "${out}" overall precision)
          string(JSON sk GET "${out}" overall shadow_kept)
          foreach(v recall hand_min foot_min precision sr sp sk)
            percent("${${v}}" ${v})
          endforeach()
          foreach(v recall hand_min foot_min precision)
            pad("${${v}}" 8 ${v})
          endforeach()
          pad("${sr}" 10 sr)
          pad("${sp}" 9 sp)
          pad("${sk}" 12 sk)
          string(APPEND row "${recall}  ${hand_min}  ${foot_min}   ${precision} |${sr}${sp}${sk} |${part_cols}")
        endif()
        table_row("${row}")
      endforeach()
    endforeach()
  endforeach()
endforeach()
table_finish(hull_sweep)
