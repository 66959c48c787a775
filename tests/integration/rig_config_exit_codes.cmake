# `voxcap rig --config FILE` on bad input: every case must end with exit code 2 (README.md, "Commands")
# and a one-line message naming the problem. Run by CTest with -DVOXCAP=<voxcap> -DSOURCE=<source dir>
# -DWORK=<a scratch folder>.
file(MAKE_DIRECTORY ${WORK})
file(READ ${SOURCE}/hw/rigs/emulated.toml good)
string(REPLACE "calibration = \"emulated.yaml\"" "calibration = \"${SOURCE}/hw/rigs/emulated.yaml\"" good "${good}")

set(cases missing syntax unknown_key id_without_number)
file(WRITE ${WORK}/syntax.toml "version = 1\n[grid\n")
string(REPLACE "[features]" "[features]\nenabeld = true" text "${good}")
file(WRITE ${WORK}/unknown_key.toml "${text}")
string(REPLACE "id = \"node1\"" "id = \"side-b\"" text "${good}")
file(WRITE ${WORK}/id_without_number.toml "${text}")
set(expect_missing "missing.toml")
set(expect_syntax "syntax")
set(expect_unknown_key "enabeld")
set(expect_id_without_number "nodes\\[1\\].id: 'side-b' must be or end in the node's number")

foreach(c ${cases})
  execute_process(COMMAND ${VOXCAP} rig --config ${WORK}/${c}.toml --seconds 0.1 --record ${WORK}/rec
                  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "${c}: exit code ${rc}, expected 2\n${out}${err}")
  endif()
  if(NOT err MATCHES "${expect_${c}}")
    message(FATAL_ERROR "${c}: the message does not say '${expect_${c}}':\n${err}")
  endif()
  message(STATUS "${c}: 2, ${err}")
endforeach()
