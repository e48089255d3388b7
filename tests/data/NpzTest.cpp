// Tests src/data/Npz.cpp: .npz files written by numpy (np.savez,
// np.savez_compressed, .npy versions 1.0 to 3.0, float16/32/64) when
// /usr/bin/python3 has numpy, our own writer read back by numpy, and
// hostile files built here.

#include "data/Npz.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "common/FileIo.h"
#include "support/TestPaths.h"
#include "support/TestUtil.h"

namespace vln::data {
namespace {

namespace fs = std::filesystem;
using ::testing::AllOf;
using ::testing::HasSubstr;
using vln::test::errorOf;

bool haveNumpy() {
  return fs::exists("/usr/bin/python3") &&
         vln::test::runCommand("/usr/bin/python3 -c 'import numpy'") == 0;
}

// runs a Python script with numpy as np, in `dir`
void runPython(const fs::path& dir, const std::string& script) {
  const fs::path file = vln::test::writeText(dir / "script.py", script);
  std::string output;
  ASSERT_EQ(
      vln::test::runCommand("cd " + dir.string() + " && /usr/bin/python3 " +
                                file.string() + " 2>&1",
                            &output),
      0)
      << output;
}

NpyArray arange(std::vector<int64_t> shape, float scale = 0.5f) {
  NpyArray a;
  a.shape = std::move(shape);
  int64_t n = 1;
  for (int64_t d : a.shape) n *= d;
  for (int64_t i = 0; i < n; ++i)
    a.values.push_back(static_cast<float>(i) * scale - 1.0f);
  return a;
}

// =========================================================================
// numpy interop
// =========================================================================

TEST(NpzTest, ReadsNumpySavezAndSavezCompressed) {
  if (!haveNumpy()) GTEST_SKIP() << "no /usr/bin/python3 with numpy";
  vln::test::TempDir dir;
  runPython(dir.path(), R"(
import numpy as np
a = (np.arange(12, dtype=np.float32) * 0.5 - 1.0).reshape(3, 4)
kw = dict(features=a, f8=np.array([1.5, -2.25, 1e-3]), f2=np.array(
    [0.5, -2.0, 65504.0, 6e-8], dtype=np.float16), scalar=np.float32(7.0),
    empty=np.zeros((0, 768), dtype=np.float32))
np.savez('plain.npz', **kw)
np.savez_compressed('compressed.npz', **kw)
)");
  for (const char* name : {"plain.npz", "compressed.npz"}) {
    SCOPED_TRACE(name);
    const NpzArrays arrays = readNpz(dir / name);
    ASSERT_EQ(arrays.size(), 5u);
    EXPECT_EQ(arrays.at("features"), arange({3, 4}));
    EXPECT_EQ(arrays.at("f8").shape, (std::vector<int64_t>{3}));
    EXPECT_EQ(arrays.at("f8").values,
              (std::vector<float>{1.5f, -2.25f, static_cast<float>(1e-3)}));
    // float16: exact halves, the largest finite half and a subnormal
    const auto& f2 = arrays.at("f2").values;
    ASSERT_EQ(f2.size(), 4u);
    EXPECT_EQ(f2[0], 0.5f);
    EXPECT_EQ(f2[1], -2.0f);
    EXPECT_EQ(f2[2], 65504.0f);
    EXPECT_NEAR(f2[3], 5.96e-8f, 1e-9f);
    EXPECT_TRUE(arrays.at("scalar").shape.empty());
    EXPECT_EQ(arrays.at("scalar").values, (std::vector<float>{7.0f}));
    EXPECT_EQ(arrays.at("empty").shape, (std::vector<int64_t>{0, 768}));
    EXPECT_TRUE(arrays.at("empty").values.empty());
  }
}

TEST(NpzTest, ReadsNpyVersionsOneTwoAndThree) {
  if (!haveNumpy()) GTEST_SKIP() << "no /usr/bin/python3 with numpy";
  vln::test::TempDir dir;
  runPython(dir.path(), R"(
import io, zipfile
import numpy as np
a = (np.arange(6, dtype=np.float32) * 0.5 - 1.0).reshape(2, 3)
with zipfile.ZipFile('versions.npz', 'w', zipfile.ZIP_DEFLATED) as z:
    for v in [(1, 0), (2, 0), (3, 0)]:
        b = io.BytesIO()
        np.lib.format.write_array(b, a, version=v)
        z.writestr('v%d.npy' % v[0], b.getvalue())
)");
  const NpzArrays arrays = readNpz(dir / "versions.npz");
  ASSERT_EQ(arrays.size(), 3u);
  for (const char* name : {"v1", "v2", "v3"})
    EXPECT_EQ(arrays.at(name), arange({2, 3})) << name;
}

TEST(NpzTest, NumpyReadsWhatWriteNpzWrites) {
  if (!haveNumpy()) GTEST_SKIP() << "no /usr/bin/python3 with numpy";
  vln::test::TempDir dir;
  writeNpz(dir / "ours.npz", {{"features", arange({4, 768}, 0.25f)},
                              {"one", arange({5})},
                              {"scalar", {{}, {3.0f}}}});
  runPython(dir.path(), R"(
import numpy as np
z = np.load('ours.npz')
assert sorted(z.files) == ['features', 'one', 'scalar'], z.files
f = z['features']
assert f.dtype == np.float32 and f.shape == (4, 768), (f.dtype, f.shape)
assert np.array_equal(f.ravel(), np.arange(4 * 768, dtype=np.float32) * 0.25 - 1)
assert z['one'].shape == (5,) and z['scalar'].shape == () and z['scalar'] == 3
)");
}

TEST(NpzTest, RefusesWhatNumpyWritesButWeDoNotRead) {
  if (!haveNumpy()) GTEST_SKIP() << "no /usr/bin/python3 with numpy";
  vln::test::TempDir dir;
  runPython(dir.path(), R"(
import numpy as np
a = np.arange(6, dtype=np.float32).reshape(2, 3)
np.savez('fortran.npz', features=np.asfortranarray(a))
np.savez('big.npz', features=a.astype('>f4'))
np.savez('ints.npz', features=a.astype(np.int32))
np.savez('object.npz', features=np.array([1, 'a'], dtype=object))
np.savez_compressed('bomb.npz', features=np.zeros((512, 768), np.float32))
)");
  const auto fails = [&](const char* name, const NpzLimits& limits = {}) {
    return errorOf([&] { readNpz(dir / name, limits); });
  };
  EXPECT_THAT(fails("fortran.npz"),
              AllOf(HasSubstr("fortran.npz"), HasSubstr("array 'features'"),
                    HasSubstr("fortran_order")));
  EXPECT_THAT(fails("big.npz"),
              AllOf(HasSubstr("array 'features'"), HasSubstr("'>f4'")));
  EXPECT_THAT(fails("ints.npz"), HasSubstr("unsupported dtype '<i4'"));
  EXPECT_THAT(fails("object.npz"), HasSubstr("dtype '|O'"));
  // 1.5 MB of zeros deflate to a few kB: refused by the limit, not inflated
  EXPECT_THAT(fails("bomb.npz", {.max_total_bytes = 1 << 20}),
              AllOf(HasSubstr("bomb.npz"), HasSubstr("features.npy"),
                    HasSubstr("more than the 1048576 allowed")));
  EXPECT_EQ(readNpz(dir / "bomb.npz").at("features").values.size(),
            512u * 768u);
}

// =========================================================================
// our own round trip and hostile files
// =========================================================================

TEST(NpzTest, RoundTripsThroughWriteNpz) {
  vln::test::TempDir dir;
  const NpzArrays arrays = {{"a", arange({2, 3, 4})}, {"b", arange({0})}};
  writeNpz(dir / "x.npz", arrays);
  EXPECT_EQ(readNpz(dir / "x.npz"), arrays);
  EXPECT_THAT(errorOf([&] {
                writeNpz(dir / "y.npz", {{"a", {{2, 2}, {1}}}});
              }),
              HasSubstr("shape holds 4 values, the array 1"));
  EXPECT_FALSE(fs::exists(dir / "y.npz"));
}

// a .npy whose header text is `header` followed by `data`
std::string npyWithHeader(const std::string& header, const std::string& data) {
  std::string bytes("\x93NUMPY\x01\x00", 8);
  const std::string text = header + "\n";
  bytes += static_cast<char>(text.size() & 0xff);
  bytes += static_cast<char>(text.size() >> 8);
  return bytes + text + data;
}

TEST(NpzTest, RefusesMalformedNpyNamingTheArray) {
  const std::string four(16, '\0');
  const auto fails = [&](const std::string& header, const std::string& data) {
    return errorOf([&] { parseNpy(npyWithHeader(header, data), "ctx"); });
  };
  const std::string ok =
      "{'descr': '<f4', 'fortran_order': False, 'shape': (4,), }";
  EXPECT_EQ(fails(ok, four), "");
  EXPECT_THAT(fails(ok, four.substr(0, 12)),
              AllOf(HasSubstr("ctx"), HasSubstr("truncated")));
  EXPECT_THAT(fails(ok, four + "xx"), HasSubstr("the file holds 18"));
  EXPECT_THAT(fails("{'descr': '<f4', 'shape': (4,), }", four),
              HasSubstr("are required"));
  EXPECT_THAT(fails("{'descr': '<f4', 'descr': '<f4', 'fortran_order': False, "
                    "'shape': (4,)}",
                    four),
              HasSubstr("repeated key 'descr'"));
  EXPECT_THAT(
      fails("{'descr': '<f4', 'fortran_order': Maybe, 'shape': (4,)}", four),
      HasSubstr("True or False"));
  EXPECT_THAT(
      fails("{'descr': '<f4', 'fortran_order': False, 'shape': (-4,)}", four),
      HasSubstr("non-negative integer"));
  EXPECT_THAT(fails("{'descr': '<f4', 'fortran_order': False, 'shape': "
                    "(99999999999, 99999999999, 99999999999)}",
                    four),
              HasSubstr("more than the 16 data bytes"));
  EXPECT_THAT(fails("{'descr': '<f4', 'fortran_order': False, 'shape': "
                    "(99999999999999999999,)}",
                    four),
              HasSubstr("overflows"));
  EXPECT_THAT(errorOf([] { parseNpy("not an array", "ctx"); }),
              HasSubstr("no \\x93NUMPY magic"));
  std::string v9 = npyWithHeader(ok, four);
  v9[6] = 9;
  EXPECT_THAT(errorOf([&] { parseNpy(v9, "ctx"); }), HasSubstr("version 9.0"));
  std::string longHeader = npyWithHeader(ok, four);
  longHeader[8] = '\xff';
  longHeader[9] = '\x7f';
  EXPECT_THAT(errorOf([&] { parseNpy(longHeader, "ctx"); }),
              HasSubstr("runs past"));
}

TEST(NpzTest, RefusesHostileArchivesNamingFileAndArray) {
  vln::test::TempDir dir;
  const std::string good = npyBytes(arange({2, 2}));
  const auto fails = [&](const std::string& bytes,
                         const NpzLimits& limits = {}) {
    common::writeFileAtomic(dir / "bad.npz", bytes);
    return errorOf([&] { readNpz(dir / "bad.npz", limits); });
  };
  // duplicate names, entries that are no arrays
  EXPECT_THAT(fails(storedZipBytes({{"x.npy", good}, {"x.npy", good}})),
              AllOf(HasSubstr("bad.npz"), HasSubstr("entry 'x.npy'"),
                    HasSubstr("twice")));
  EXPECT_THAT(fails(storedZipBytes({{"notes.txt", "hi"}})),
              HasSubstr("entry 'notes.txt' is not a .npy array"));
  // a truncated array inside an intact archive
  EXPECT_THAT(
      fails(storedZipBytes({{"f.npy", good.substr(0, good.size() - 3)}})),
      AllOf(HasSubstr("array 'f'"), HasSubstr("truncated")));
  // damage caught by the zip checks: a flipped data byte, a cut archive
  std::string flipped = storedZipBytes({{"f.npy", good}});
  flipped[flipped.find("fortran_order")] ^= 0x20;
  EXPECT_THAT(fails(flipped), AllOf(HasSubstr("bad.npz"), HasSubstr("CRC-32")));
  EXPECT_THAT(fails(flipped.substr(0, flipped.size() / 2)),
              HasSubstr("bad.npz"));
  EXPECT_THAT(fails("PK\x03\x04 not really"), HasSubstr("bad.npz"));
  // limits on entry count and total size
  EXPECT_THAT(fails(storedZipBytes({{"a.npy", good}, {"b.npy", good}}),
                    {.max_arrays = 1}),
              HasSubstr("2 entries, more than the 1 allowed"));
  EXPECT_THAT(fails(storedZipBytes({{"a.npy", good}}), {.max_total_bytes = 10}),
              HasSubstr("more than the 10 allowed"));
  EXPECT_THAT(errorOf([&] { readNpz(dir / "missing.npz"); }),
              HasSubstr("missing.npz"));
}

}  // namespace
}  // namespace vln::data
