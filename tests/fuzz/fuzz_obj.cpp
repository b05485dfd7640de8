// libFuzzer target: the OBJ loader. loadObj takes a path, so each input is
// written to one temporary file (input-<pid>.obj in a folder made at start-up under
// $TMPDIR or /tmp, or in SWARMSIM_FUZZ_TMPDIR when set; removed at exit) and
// loaded from there, then isWatertight and bounds run on the mesh.
//
// The placement is one of three fixed transforms, chosen by the input size:
// identity; scale, rotate and translate; and a huge scale, so that "not finite
// after the transform" is reachable.
//
// Findings: see fuzz_util.hpp. A loaded mesh must have triangles, finite
// vertices and triangle indices within its vertices (signedDistance and the
// models index vertices by them unchecked).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <system_error>
#include <vector>

#include "fuzz_util.hpp"
#include "geometry/mesh.hpp"

namespace fs = std::filesystem;
using swarmsim_fuzz::finding;

namespace {

fs::path gDir;       // made by us, removed at exit (unless given)
bool gOwnDir = false;
std::string gFile;   // gDir / input.obj

void removeDir() {
  std::error_code ec;
  if (gOwnDir) fs::remove_all(gDir, ec);
}

swarmsim::MeshTransform transformFor(std::size_t size) {
  swarmsim::MeshTransform t;
  switch (size % 3) {
    case 1:
      t.scale = swarmsim::Vec3d(2.0, 0.5, 3.0);
      t.rotateDeg = swarmsim::Vec3d(90.0, 30.0, -45.0);
      t.translate = swarmsim::Vec3d(1.0, -2.0, 0.25);
      break;
    case 2:
      t.scale = swarmsim::Vec3d::Constant(1e300);
      break;
    default:
      break;
  }
  return t;
}

void writeInput(const std::uint8_t* data, std::size_t size) {
  std::FILE* f = std::fopen(gFile.c_str(), "wb");
  if (!f) finding("harness: cannot write " + gFile);
  if (size > 0 && std::fwrite(data, 1, size, f) != size) finding("harness: short write to " + gFile);
  if (std::fclose(f) != 0) finding("harness: cannot close " + gFile);
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  const char* given = std::getenv("SWARMSIM_FUZZ_TMPDIR");
  if (given && *given) {
    gDir = given;
    std::error_code ec;
    fs::create_directories(gDir, ec);
  } else {
    const char* tmp = std::getenv("TMPDIR");
    std::string tmpl = (fs::path(tmp && *tmp ? tmp : "/tmp") / "swarmsim-fuzz-obj-XXXXXX").string();
    std::vector<char> buf(tmpl.begin(), tmpl.end());
    buf.push_back('\0');
    if (!mkdtemp(buf.data())) finding("harness: mkdtemp failed for " + tmpl);
    gDir = buf.data();
    gOwnDir = true;
    std::atexit(removeDir);
  }
  gFile = (gDir / ("input-" + std::to_string(getpid()) + ".obj")).string();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  writeInput(data, size);
  swarmsim_fuzz::expectOnlySwarmsimErrors([&] {
    const swarmsim::TriangleMesh mesh = swarmsim::loadObj(gFile, transformFor(size));
    if (mesh.triangles.empty()) finding("loadObj returned a mesh without triangles");
    for (const auto& v : mesh.vertices) {
      if (!v.allFinite()) finding("loadObj returned a non-finite vertex");
    }
    for (const auto& t : mesh.triangles) {
      for (const std::uint32_t i : t) {
        if (i >= mesh.vertices.size()) {
          finding("loadObj returned triangle index " + std::to_string(i) + " with " +
                  std::to_string(mesh.vertices.size()) + " vertices");
        }
      }
    }
    (void)swarmsim::isWatertight(mesh);
    (void)mesh.bounds();
  });
  return 0;
}
