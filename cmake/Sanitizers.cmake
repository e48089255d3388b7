# ASan + UBSan for the whole tree (VLN_SANITIZE=ON). Applied globally so that
# static libraries and tests agree on the instrumented runtime.
if(VLN_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer
    -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
endif()
