# Shared build settings and helpers for every folder.
include_guard(GLOBAL)
include(GoogleTest)

add_library(vc_warnings INTERFACE)
target_compile_options(vc_warnings INTERFACE
  -Wall -Wextra -Wshadow -Wformat=2 -Wundef
  $<$<COMPILE_LANGUAGE:C>:-Wstrict-prototypes -Wmissing-prototypes>
  $<$<BOOL:${VOXCAP_WERROR}>:-Werror>)

if(VOXCAP_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
if(VOXCAP_LTO)
  set(CMAKE_INTERPROCEDURAL_OPTIMIZATION ON)
endif()

# vc_test(NAME <name> SOURCES <files...> LIBS <targets...> LABELS <labels...> [TIMEOUT <s>] [SERIAL])
# A GoogleTest binary whose cases are registered with CTest one by one, labelled. SERIAL: its cases
# run alone (whole-rig tests that need both cores).
function(vc_test)
  cmake_parse_arguments(T "SERIAL" "NAME;TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 300)
  endif()
  add_executable(${T_NAME} ${T_SOURCES})
  target_link_libraries(${T_NAME} PRIVATE ${T_LIBS} GTest::gtest GTest::gmock GTest::gtest_main vc_warnings)
  target_compile_definitions(${T_NAME} PRIVATE
    VOXCAP_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    VOXCAP_BINARY_DIR="${PROJECT_BINARY_DIR}"
    VOXCAP_SHARED_DIR="${PROJECT_SOURCE_DIR}/../shared")
  gtest_discover_tests(${T_NAME}
    DISCOVERY_MODE PRE_TEST
    PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT} RUN_SERIAL ${T_SERIAL}
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
endfunction()
