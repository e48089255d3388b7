# All third-party packages come from Debian (scripts/setup.sh installs them).
# Each is found once here and exposed as an imported or interface target.
find_package(Threads REQUIRED)
find_package(ZLIB REQUIRED)
find_package(Eigen3 3.4 REQUIRED NO_MODULE)
find_package(yaml-cpp REQUIRED)
find_package(spdlog REQUIRED)
find_package(nlohmann_json 3.10 REQUIRED)
find_package(CLI11 REQUIRED)
find_package(assimp REQUIRED)
find_package(embree 3 REQUIRED)
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs videoio)
find_package(PkgConfig REQUIRED)
pkg_check_modules(OSMESA REQUIRED IMPORTED_TARGET osmesa)

# Recast/Detour: Debian ships libraries and headers but no CMake package.
find_path(RECAST_INCLUDE_DIR Recast.h PATH_SUFFIXES recastnavigation REQUIRED)
find_library(RECAST_LIBRARY Recast REQUIRED)
find_library(DETOUR_LIBRARY Detour REQUIRED)
add_library(vln_recast INTERFACE)
target_include_directories(vln_recast SYSTEM INTERFACE ${RECAST_INCLUDE_DIR})
target_link_libraries(vln_recast INTERFACE ${DETOUR_LIBRARY} ${RECAST_LIBRARY})

find_path(LMDB_INCLUDE_DIR lmdb.h REQUIRED)
find_library(LMDB_LIBRARY lmdb REQUIRED)
add_library(vln_lmdb INTERFACE)
target_include_directories(vln_lmdb SYSTEM INTERFACE ${LMDB_INCLUDE_DIR})
target_link_libraries(vln_lmdb INTERFACE ${LMDB_LIBRARY})

# LibTorch, wrapped once. Its headers are SYSTEM so our warning flags do not
# flood the build with its diagnostics.
find_package(Torch REQUIRED)
add_library(vln_torch INTERFACE)
target_include_directories(vln_torch SYSTEM INTERFACE ${TORCH_INCLUDE_DIRS})
target_link_libraries(vln_torch INTERFACE ${TORCH_LIBRARIES})
add_library(vln::torch ALIAS vln_torch)

# One precompiled torch header shared by every target that includes LibTorch
# (vln_use_torch_pch). Compiling <torch/torch.h> costs ~15 s per translation
# unit on these machines; the PCH pays that once.
add_library(vln_torch_pch STATIC ${PROJECT_SOURCE_DIR}/cmake/TorchPch.cpp)
target_link_libraries(vln_torch_pch PRIVATE vln_torch vln_warnings)
target_precompile_headers(vln_torch_pch PRIVATE <torch/torch.h>)

# vln_reuse_pch(<target> <pch target>): <target> compiles with the precompiled
# header of <pch target> (a static library that owns it).
function(vln_reuse_pch target pch)
  target_precompile_headers(${target} REUSE_FROM ${pch})
  get_target_property(type ${target} TYPE)
  if(type STREQUAL "EXECUTABLE")
    # A static library's PCH is compiled -fPIC; gcc refuses it in
    # translation units compiled -fPIE, which CMake uses for executables.
    # -fPIC objects link into a PIE executable just as well.
    set_target_properties(${target} PROPERTIES POSITION_INDEPENDENT_CODE OFF)
    target_compile_options(${target} PRIVATE -fPIC)
  endif()
endfunction()

function(vln_use_torch_pch target)
  vln_reuse_pch(${target} vln_torch_pch)
endfunction()
