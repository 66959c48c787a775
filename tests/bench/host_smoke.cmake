# Runs `voxcap bench host` on a tiny setting and checks every documented key of its JSON.
execute_process(
  COMMAND ${VOXCAP} bench host --json --grid 64 --nodes 3 --repeats 3 --tri-frames 5 --fit-frames 20 --fit-grid 48 --minutes 0.05 --size 160x120 --rig-grid 32
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "voxcap bench host failed (${rc}): ${err}")
endif()
foreach(path "merge;0;nodes" "merge;0;grid" "merge;0;voxels" "merge;0;rle_bytes_per_node" "merge;0;merged_occupied"
             "merge;0;merge_ns_per_frame" "merge;0;merge_ns_p99" "rig;fps" "rig;frames" "rig;complete"
             "rig;degraded" "rig;pulses" "rig;seconds" "rig;trigger_to_merged_ms;p50" "rig;trigger_to_merged_ms;p99" "rig;rejoin_ms"
             "rig;host_rss_kb;start" "rig;host_rss_kb;end" "triangulate;0;cameras" "triangulate;1;cameras"
             "triangulate;0;frames" "triangulate;0;ns_per_frame" "triangulate;0;ns_p99" "triangulate;0;err3d_mm_p50"
             "fit;motion" "fit;grid" "fit;voxel_m" "fit;samples" "fit;steps" "fit;frames" "fit;fitted_frames"
             "fit;decode;us" "fit;torso_segmentation;us" "fit;pca;us" "fit;layer1;us" "fit;layer2_segment;us"
             "fit;layer2_all;us" "fit;total;us" "fit;total;us_p99" "fit;mpjpe_mm" "fit;paper_table1_ms;pca")
  string(JSON v ERROR_VARIABLE e GET "${out}" ${path})
  if(e)
    message(FATAL_ERROR "key ${path} missing: ${e}\n${out}")
  endif()
endforeach()
string(JSON frames GET "${out}" rig frames)
if(frames LESS 1)
  message(FATAL_ERROR "the rig merged no frame:\n${out}")
endif()
message(STATUS "bench host smoke ok")
