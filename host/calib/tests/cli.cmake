# voxcap calib import and voxcap carve from the command line (run by CTest with -DVOXCAP=<voxcap>
# -DDATA=<shared/data/multiview> -DWORK=<a scratch folder>):
# - every bad input is exit code 2 and exactly one line on stderr naming the problem (issue #13);
# - the Middlebury dino imported and carved with --auto, every output written (PLY, .npy, preview).
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
file(WRITE ${WORK}/deep.json "{\"cameras\": ")
foreach(i RANGE 200)
  file(APPEND ${WORK}/deep.json "[")
endforeach()
file(WRITE ${WORK}/nan_par.txt "v.png 1000 0 320 0 1000 240 0 0 1 1 0 0 0 0 -1 0 1 0 0 1 nan\n")
file(WRITE ${WORK}/far_par.txt "v.png 1000 0 320 0 1000 240 0 0 1 1.1 0 0 0 0 -1 0 1 0 0 1 3\n")
file(WRITE ${WORK}/doctype.qca "<!DOCTYPE x [<!ENTITY a \"b\">]><calibration/>\n")
file(WRITE ${WORK}/fish.toml "[cam_1]\nsize = [640.0, 480.0]\nmatrix = [[1000.0, 0.0, 320.0], [0.0, 1000.0, 240.0], [0.0, 0.0, 1.0]]\ndistortions = [0.0, 0.0, 0.0, 0.0]\nrotation = [0.0, 0.0, 0.0]\ntranslation = [0.0, 0.0, 3.0]\nfisheye = true\n")

set(cases)
macro(case name expect)
  list(APPEND cases ${name})
  set(expect_${name} "${expect}")
  set(args_${name} ${ARGN})
endmacro()
case(unknown_format "--from must be" calib import --from colmap ${WORK}/nan_par.txt -o ${WORK}/x.yaml)
case(missing_file "cannot open|No such file" calib import --from panoptic ${WORK}/none.json -o ${WORK}/x.yaml)
case(deep_json "nested more than 32" calib import --from panoptic ${WORK}/deep.json -o ${WORK}/x.yaml)
case(nan "not a finite number" calib import --from middlebury --image-size 640 480 ${WORK}/nan_par.txt -o ${WORK}/x.yaml)
case(far_rotation "camera 'v': R is not a rotation" calib import --from middlebury --image-size 640 480 ${WORK}/far_par.txt -o ${WORK}/x.yaml)
case(no_image_size "--image-size" calib import --from middlebury ${WORK}/far_par.txt -o ${WORK}/x.yaml)
case(doctype "DOCTYPE" calib import --from qualisys ${WORK}/doctype.qca -o ${WORK}/x.yaml)
case(fisheye "fisheye" calib import --from toml ${WORK}/fish.toml -o ${WORK}/x.yaml)
case(bad_units "--units must be" calib import --from toml --units furlong ${WORK}/fish.toml -o ${WORK}/x.yaml)
case(units_fixed "states its own units" calib import --from qualisys --units mm ${WORK}/doctype.qca -o ${WORK}/x.yaml)
case(fifo "not a regular file" calib import --from panoptic ${WORK}/fifo -o ${WORK}/x.yaml)
case(carve_no_source "exactly one of" carve --calib ${WORK}/x.yaml --images ${WORK} --out ${WORK}/h.ply)
case(carve_two_grids "either --grid-min" carve --calib ${WORK}/x.yaml --images ${WORK} --threshold 0.5 --auto 32
     --grid-min 0 0 0 --voxel 0.01 --dims 8 8 8 --out ${WORK}/h.ply)
case(carve_threshold "--threshold must be in" carve --calib ${WORK}/x.yaml --images ${WORK} --threshold 2 --out ${WORK}/h.ply)
case(carve_dims "dimensions must be in" carve --calib ${WORK}/x.yaml --images ${WORK} --threshold 0.5
     --grid-min 0 0 0 --voxel 0.01 --dims 100000 8 8 --out ${WORK}/h.ply)
case(carve_nan_voxel "voxel" carve --calib ${WORK}/x.yaml --images ${WORK} --threshold 0.5
     --grid-min 0 0 0 --voxel nan --dims 8 8 8 --out ${WORK}/h.ply)
case(carve_no_calib "x.yaml" carve --calib ${WORK}/x.yaml --images ${WORK} --threshold 0.5 --auto 32 --out ${WORK}/h.ply)
case(carve_no_images "images for 0 camera" carve --calib ${WORK}/dino.yaml --images ${WORK} --threshold 0.5 --auto 32
     --out ${WORK}/h.ply)

# The good path first (carve_no_images needs dino.yaml).
execute_process(COMMAND ${VOXCAP} calib import --from middlebury ${DATA}/middlebury_dino/dino_par.txt -o ${WORK}/dino.yaml
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 60)
if(NOT rc EQUAL 0 OR NOT out MATCHES "363 cameras" OR NOT out MATCHES "re-orthonormalised 363 rotation")
  message(FATAL_ERROR "dino import: exit ${rc}\n${out}${err}")
endif()
execute_process(COMMAND mkfifo ${WORK}/fifo)
execute_process(COMMAND ${VOXCAP} carve --calib ${WORK}/dino.yaml --images ${DATA}/middlebury_dino/images
                --threshold 0.19 --dilate 10 --erode 7 --auto 48 --out ${WORK}/dino.ply --npy ${WORK}/dino.npy
                --preview ${WORK}/dino.png
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 120)
if(NOT rc EQUAL 0 OR NOT out MATCHES "16 cameras matched, 347 without images left out")
  message(FATAL_ERROR "dino carve: exit ${rc}\n${out}${err}")
endif()
foreach(f dino.ply dino.npy dino.png)
  if(NOT EXISTS ${WORK}/${f})
    message(FATAL_ERROR "dino carve wrote no ${f}\n${out}")
  endif()
endforeach()
message(STATUS "dino: ${out}")

foreach(c ${cases})
  execute_process(COMMAND ${VOXCAP} ${args_${c}} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 30)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "${c}: exit code ${rc}, expected 2\n${out}${err}")
  endif()
  string(REGEX REPLACE "\n$" "" line "${err}")
  if(line MATCHES "\n" OR line STREQUAL "")
    message(FATAL_ERROR "${c}: not exactly one line on stderr:\n${err}")
  endif()
  if(NOT line MATCHES "${expect_${c}}")
    message(FATAL_ERROR "${c}: the message does not say '${expect_${c}}':\n${err}")
  endif()
  message(STATUS "${c}: 2, ${line}")
endforeach()
