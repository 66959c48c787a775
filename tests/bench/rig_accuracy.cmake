# The accuracy sweep of issue #10: `voxcap rig --emulated --json` over a matrix of motions, node counts,
# appearances and rooms, one table (stdout, and TABLE when given) with each cell's body recall overall,
# per part group and for the worst hand and foot, the hull's precision, and the edges' masks (recall,
# precision, floor shadow kept: from the edges' real masks, "-" when no edge sent them). Too long for CI
# (144 cells of ~15-25 s at 640x480 / 128^3); one cell runs in the integration tests
# (EmulatedRig.SweepCellReportsPerPartHullAndSilhouetteFigures). A release build is meant:
#
#   cmake -DVOXCAP=build/release/bin/voxcap -P tests/bench/rig_accuracy.cmake
#   cmake -DVOXCAP=... -DMOTIONS="wave;walk" -DNODES=3 -DAPPEARANCES=default -DROOMS="default;camouflage" \
#         -DFRAMES=600 -DGRID=128 -DSIZE=640x480 -DCARVE=footprint -DJSON_DIR=/tmp/sweep -DTABLE=sweep.txt \
#         -P tests/bench/rig_accuracy.cmake
#
# Defaults: the whole matrix (wave walk squat turn arms-close cross; 3 and 4 nodes; every appearance
# preset; both rooms), 600 frames, 128^3, 640x480, truth every 10th frame, the rig's default carve rule.
# A cell whose run fails is a row saying so; the script goes on and exits 1 at the end.
cmake_minimum_required(VERSION 3.19)  # string(JSON)

if(NOT VOXCAP)
  message(FATAL_ERROR "rig_accuracy: -DVOXCAP=path/to/voxcap is required")
endif()
foreach(pair "MOTIONS;wave;walk;squat;turn;arms-close;cross" "NODES;3;4"
             "APPEARANCES;default;pale;olive;brown;dark;beige" "ROOMS;default;camouflage" "FRAMES;600"
             "GRID;128" "SIZE;640x480" "TRUTH_EVERY;10")
  list(POP_FRONT pair var)
  if(NOT DEFINED ${var})
    set(${var} "${pair}")
  endif()
endforeach()
set(carve_args)
if(CARVE)
  set(carve_args --carve ${CARVE})
endif()
if(JSON_DIR)
  file(MAKE_DIRECTORY "${JSON_DIR}")
endif()

include(${CMAKE_CURRENT_LIST_DIR}/table_format.cmake)  # percent(), pad()

set(parts head torso l_upper_arm r_upper_arm l_forearm r_forearm l_hand r_hand l_thigh r_thigh l_shank r_shank
          l_foot r_foot)
set(part_heads head torso luarm ruarm lfore rfore lhand rhand lthig rthig lshnk rshnk lfoot rfoot)
set(header "motion     nodes appearance room       |  recall  hand_min  foot_min  precision | sil_recall sil_prec shadow_kept sil_frames missing |")
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
          COMMAND ${VOXCAP} rig --emulated --json --nodes ${nodes} --motion ${motion} --appearance ${appearance}
                  --room ${room} --frames ${FRAMES} --grid ${GRID} --size ${SIZE} --truth-every ${TRUTH_EVERY}
                  ${carve_args}
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
          string(JSON recall GET "${out}" accuracy body_recall)
          string(JSON precision GET "${out}" accuracy hull_precision)
          string(JSON sil_frames GET "${out}" accuracy silhouettes frames)
          string(JSON sil_missing GET "${out}" accuracy silhouettes missing)
          set(hand_min 2)
          set(foot_min 2)
          set(part_cols "")
          foreach(p IN LISTS parts)
            string(JSON v GET "${out}" accuracy parts ${p})
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
          percent("${recall}" recall)
          percent("${hand_min}" hand_min)
          percent("${foot_min}" foot_min)
          percent("${precision}" precision)
          if(sil_frames GREATER 0)
            string(JSON sr GET "${out}" accuracy silhouettes recall)
            string(JSON sp GET "${out}" accuracy silhouettes precision)
            string(JSON sk GET "${out}" accuracy silhouettes shadow_kept)
            percent("${sr}" sr)
            percent("${sp}" sp)
            percent("${sk}" sk)
          else()
            set(sr "-")
            set(sp "-")
            set(sk "-")
          endif()
          foreach(v recall hand_min foot_min precision)
            pad("${${v}}" 8 ${v})
          endforeach()
          pad("${sr}" 10 sr)
          pad("${sp}" 9 sp)
          pad("${sk}" 12 sk)
          pad("${sil_frames}" 11 sil_frames)
          pad("${sil_missing}" 8 sil_missing)
          string(APPEND row "${recall}  ${hand_min}  ${foot_min}   ${precision} |${sr}${sp}${sk}${sil_frames}${sil_missing} |"
                 "${part_cols}")
        endif()
        table_row("${row}")
      endforeach()
    endforeach()
  endforeach()
endforeach()
table_finish(rig_accuracy)
