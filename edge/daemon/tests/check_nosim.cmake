# A voxcap-edge without the sim backend (VOXCAP_SIM=OFF) carries no renderer and says so clearly.
#   cmake -DEDGE=path/to/voxcap-edge -DNM=nm -P check_nosim.cmake
# 1. No symbol of hw/sim (namespace vc::sim, the renderer and the scene) and no sim camera backend.
execute_process(COMMAND ${NM} -C ${EDGE} OUTPUT_VARIABLE syms RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${NM} ${EDGE} failed (${rc})")
endif()
string(REGEX MATCHALL "[^\n]*(vc::sim::|vc_camera_backend_sim|vc_camera_open_sim)[^\n]*" found "${syms}")
list(LENGTH found n)
if(n GREATER 0)
  list(SUBLIST found 0 5 some)
  string(REPLACE ";" "\n  " some "${some}")
  message(FATAL_ERROR "${EDGE} carries ${n} renderer/sim symbols, e.g.:\n  ${some}")
endif()
string(REGEX MATCHALL "[^\n]* T vc_camera_open\n" have_factory "${syms}")
if(NOT have_factory)
  message(FATAL_ERROR "${EDGE}: no vc_camera_open: is this voxcap-edge?")
endif()
# 2. A sim camera is refused with a message that says why.
execute_process(COMMAND ${EDGE} --check --camera0 sim --camera1 file:/nonexistent --trigger udp --trigger-port 1
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT out MATCHES "camera 0: FAIL camera config: sim backend not built in")
  message(FATAL_ERROR "${EDGE} --check with a sim camera said:\n${out}${err}")
endif()
message(STATUS "${EDGE}: no renderer symbols; a sim camera is refused: sim backend not built in")
