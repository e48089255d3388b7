// Bit-identical houses on every machine: never fuse a*b+c into one FMA
// instruction, even in builds for CPUs that have it (-march=native).
//
// Included by every source file of the house generator (HouseBuilder*.cpp,
// ProceduralTextures.cpp, HouseGenerator.cpp) before any other include: the
// pragma holds from here to the end of the including file, so inline header
// code included after it is covered too. Never include it from a header.
#pragma once

#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif
