// Translation unit that owns a test precompiled header (tests/CMakeLists.txt).
