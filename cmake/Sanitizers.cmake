# ASan + UBSan for the whole tree (VLN_SANITIZE=ON). Applied globally so that
# static libraries and tests agree on the instrumented runtime.
if(VLN_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
    -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
  # gcc's flow analysis misreads ASan's instrumentation: with -Werror it
  # stopped the sanitized build on a maybe-uninitialized c10::optional
  # inside LibTorch's headers (Tensor::uniform_'s default generator)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    add_compile_options(-Wno-maybe-uninitialized)
  endif()
endif()
