# tests/reliability (docs/reliability.md): fuzz crasher replays, config
# strictness, resource limits, determinism and kill -9/resume tests. Each
# tests/reliability/<Name>Test.cpp is one executable linked against the
# whole stack (vln::train). Label "reliability", except the multi-minute
# end-to-end ones, labelled "slow" so that CI can pick them by label.
file(GLOB reliability_sources CONFIGURE_DEPENDS
  ${CMAKE_CURRENT_LIST_DIR}/*Test.cpp)
foreach(source IN LISTS reliability_sources)
  get_filename_component(test_name ${source} NAME_WE)
  set(label reliability)
  if(test_name MATCHES "^(KillResume|Determinism)Test$")
    set(label slow)
  endif()
  vln_add_test(${test_name} SOURCES ${source} LIBS vln::train
    LABEL ${label} TORCH)
endforeach()
