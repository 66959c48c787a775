# Table helpers of the sweep scripts (rig_accuracy.cmake, hull_sweep.cmake); CMake has integer
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
