# `voxcap bench` forwards to voxcap-bench beside it: help, error prefix and exit code as voxcap's own,
# the same from voxcap-bench run directly, and a clear error when voxcap-bench is missing.
# -D: VOXCAP, VOXCAP_BENCH (binaries), WORK (a build-tree directory).
function(run expect_rc expect_regex)
  execute_process(COMMAND ${ARGN} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc STREQUAL "${expect_rc}")
    message(FATAL_ERROR "${ARGN}: exit ${rc}, expected ${expect_rc}\n${out}${err}")
  endif()
  if(NOT "${out}${err}" MATCHES "${expect_regex}")
    message(FATAL_ERROR "${ARGN}: output does not match '${expect_regex}':\n${out}${err}")
  endif()
endfunction()

run(0 "Usage: [^\n]*voxcap bench host \\[OPTIONS\\].*--rig-nodes.*JSON keys: merge\\[\\]" ${VOXCAP} bench host --help)
run(0 "Usage: [^\n]*voxcap bench edge \\[OPTIONS\\].*--bg-frames.*goals\\.\\*" ${VOXCAP} bench edge --help)
run(2 "^voxcap: --child needs --frames-file and one --grid\n$" ${VOXCAP} bench edge --child rss)
run(2 "^voxcap-bench: --child needs --frames-file and one --grid\n$" ${VOXCAP_BENCH} edge --child rss)
run(2 "^voxcap: --size: expected WxH\n$" ${VOXCAP} bench host --no-rig --size 3)
# bench edge --size WxH (issue #16): the Pi Global Shutter camera's 1456x1088 is the frame measured.
run(2 "^voxcap: --size: expected WxH with each side 16..4096 \\(e.g. 1456x1088\\), got '3'\n$" ${VOXCAP} bench edge --size 3)
run(2 "^voxcap: --size: expected WxH with each side 16..4096[^\n]*got '1456x1088x2'\n$" ${VOXCAP} bench edge --size 1456x1088x2)
run(2 "--width excludes --size" ${VOXCAP} bench edge --size 1456x1088 --width 640)
# CLI11's own parse errors are bad input like any other: one line, exit 2 (issue #13; was CLI11's 105).
run(2 "^voxcap: --grid: Value 2 not in range[^\n]*\n$" ${VOXCAP} bench edge --grid 2)

# voxcap alone in a folder: `voxcap bench` says what is missing (exit 1); other commands still work.
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK})
file(COPY ${VOXCAP} DESTINATION ${WORK})
get_filename_component(name ${VOXCAP} NAME)
run(1 "^voxcap: voxcap-bench not found \\(looked in [^\n]*/voxcap-bench, [^\n]*/libexec/voxcap/voxcap-bench[^\n]*; build the voxcap-bench target\\)\n$"
    ${WORK}/${name} bench edge --grid 16)
run(0 "voxcap" ${WORK}/${name} --version)
file(REMOVE_RECURSE ${WORK})
message(STATUS "voxcap bench forwards to voxcap-bench")
