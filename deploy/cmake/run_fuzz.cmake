# Runs one libFuzzer target for SECONDS from a corpus seeded with the files SEEDS (a glob, e.g.
# proto/vectors/*.bin), copied into the build tree so the source tree is never written.
# -D: FUZZER (binary), SEEDS (glob), WORK (build-tree directory), SECONDS, DICT, MAX_LEN (bytes).
file(MAKE_DIRECTORY ${WORK}/corpus ${WORK}/seeds ${WORK}/artifacts)
file(GLOB seeds ${SEEDS})
file(COPY ${seeds} DESTINATION ${WORK}/seeds)
execute_process(
  COMMAND ${FUZZER} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2560 -max_len=${MAX_LEN}
          -print_final_stats=1 -dict=${DICT} -artifact_prefix=${WORK}/artifacts/ ${WORK}/corpus ${WORK}/seeds
  RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${FUZZER} failed (exit ${rc}); the input that broke it is in ${WORK}/artifacts/")
endif()
