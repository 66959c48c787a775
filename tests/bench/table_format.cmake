# Table helpers of the sweep scripts (rig_accuracy.cmake, hull_sweep.cmake, clip_accuracy.cmake); CMake has integer
# arithmetic only.

# A fraction as a percentage with one decimal: "0.98765" -> "98.7".
function(percent value out)
  if(value MATCHES "[eE]-")
    set(${out} "0.0" PARENT_SCOPE)  # below 1e-4
    return()
  endif()
  if(NOT value MATCHES "^([0-9]+)(\\.([0-9]*))?$")
    set(${out} "?" PARENT_SCOPE)
    return()
  endif()
  set(int "${CMAKE_MATCH_1}")
  set(frac "${CMAKE_MATCH_3}000")
  string(SUBSTRING "${frac}" 0 2 whole)
  string(SUBSTRING "${frac}" 2 1 tenth)
  math(EXPR whole "${int} * 100 + 1${whole} - 100")
  set(${out} "${whole}.${tenth}" PARENT_SCOPE)
endfunction()

# text right-aligned in width columns.
function(pad text width out)
  string(LENGTH "${text}" n)
  set(s "${text}")
  while(n LESS width)
    string(PREPEND s " ")
    math(EXPR n "${n} + 1")
  endwhile()
  set(${out} "${s}" PARENT_SCOPE)
endfunction()

# One row of the table: printed now (a long sweep shows its progress) and added to the caller's
# `lines` (written to TABLE by table_finish()).
function(table_row text)
  execute_process(COMMAND ${CMAKE_COMMAND} -E echo "${text}")
  list(APPEND lines "${text}")
  set(lines "${lines}" PARENT_SCOPE)
endfunction()

# A row saying why this item failed: the script goes on, and table_finish() exits 1 at the end.
function(table_failed_row text)
  execute_process(COMMAND ${CMAKE_COMMAND} -E echo "${text}")
  list(APPEND lines "${text}")
  set(lines "${lines}" PARENT_SCOPE)
  set(failed 1 PARENT_SCOPE)
endfunction()

# The end of a sweep: the rows written to TABLE when given; exit 1 when any item failed.
function(table_finish script)
  if(TABLE)
    list(JOIN lines "\n" text)
    file(WRITE "${TABLE}" "${text}\n")
  endif()
  if(failed)
    message(FATAL_ERROR "${script}: some rows failed (rows above)")
  endif()
endfunction()
