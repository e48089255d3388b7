# tests/reliability (docs/reliability.md): fuzz crasher replays, config
# strictness, resource limits, determinism and kill -9/resume tests. Each
# tests/reliability/<Name>Test.cpp is one executable linked against the
# whole stack (vln::train), except FrozenWorldTest (the default world's
# frozen evaluation files; vlnce-data and vln::data only). Label "reliability", except
# the multi-minute end-to-end ones (they drive the train, eval and
# vlnce-data binaries), labelled "slow" with a longer timeout so that CI can
# pick them by label.
file(GLOB reliability_sources CONFIGURE_DEPENDS
  ${CMAKE_CURRENT_LIST_DIR}/*Test.cpp)
foreach(source IN LISTS reliability_sources)
  get_filename_component(test_name ${source} NAME_WE)
  if(test_name MATCHES "^(KillResume|Determinism)Test$")
    # a 1 h timeout (sanitized builds run 2-5x slower)
    vln_add_test(${test_name} SOURCES ${source} LIBS vln::train
      LABEL slow TORCH TIMEOUT 3600)
  elseif(test_name STREQUAL "FrozenWorldTest")
    # drives bin/vlnce-data only: no LibTorch; one generation of the default
    # world, about 9 s on 2 cores, so not labelled slow
    vln_add_test(${test_name} SOURCES ${source} LIBS vln::data
      LABEL reliability)
    add_dependencies(${test_name} vlnce-data)
  else()
    vln_add_test(${test_name} SOURCES ${source} LIBS vln::train
      LABEL reliability TORCH)
  endif()
endforeach()
# FuzzCrashersTest replays fuzz_geometry's recipes with fuzz/GeometryFuzzing.h
target_include_directories(FuzzCrashersTest PRIVATE ${PROJECT_SOURCE_DIR})
