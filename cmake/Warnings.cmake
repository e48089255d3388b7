# Every project target links vln_warnings PRIVATE so the flags stay uniform.
add_library(vln_warnings INTERFACE)
target_compile_options(vln_warnings INTERFACE -Wall -Wextra -Wpedantic
  -Wno-unused-parameter)
if(VLN_WERROR)
  target_compile_options(vln_warnings INTERFACE -Werror)
endif()
