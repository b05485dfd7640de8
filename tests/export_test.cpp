// The scene stored in the output, `run --from`, a scenario from standard input, `run --json` and
// `swarmsim export` (csv, ply, xdmf): docs/output.md#scene-and-inputs, docs/tools.md.
// (The real programs that read the exports are run by tests/tools/*.py.)
#include <sys/stat.h>

#include <catch2/catch.hpp>
#include <charconv>
#include <cmath>
#include <cstring>
#include <map>
#include <nlohmann/json.hpp>

#include "geometry/mesh.hpp"
#include "geometry/tessellate.hpp"
#include "io/scene_io.hpp"
#include "io/trajectory_reader.hpp"
#include "test_util.hpp"

using namespace swarmsim;
using namespace swarmsim_test;

namespace {

const std::string kScene = kSourceTree + "/tests/data/scene.json";

// signed volume of a closed mesh (positive when its triangles face outwards)
double signedVolume(const TriangleMesh& m) {
  double v = 0.0;
  for (const auto& t : m.triangles) {
    v += m.vertices[t[0]].dot(m.vertices[t[1]].cross(m.vertices[t[2]])) / 6.0;
  }
  return v;
}

std::vector<float> frameOf(const std::vector<float>& all, std::size_t agents, std::size_t f) {
  return std::vector<float>(all.begin() + static_cast<std::ptrdiff_t>(3 * agents * f),
                            all.begin() + static_cast<std::ptrdiff_t>(3 * agents * (f + 1)));
}

struct CsvRow {
  long long frame;
  double time;
  std::string swarm;
  unsigned id;
  float v[6];
};

std::vector<CsvRow> parseCsv(const std::string& text, std::string& header) {
  std::vector<CsvRow> rows;
  std::istringstream in(text);
  std::getline(in, header);
  std::string line;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string x;
    while (std::getline(ss, x, ',')) f.push_back(x);
    if (f.size() != 10) REQUIRE(f.size() == 10);  // asserted only when wrong: cheap on large exports
    CsvRow r{};
    r.frame = std::stoll(f[0]);
    r.time = std::strtod(f[1].c_str(), nullptr);
    r.swarm = f[2];
    r.id = static_cast<unsigned>(std::stoul(f[3]));
    for (int k = 0; k < 6; ++k) std::from_chars(f[4 + k].data(), f[4 + k].data() + f[4 + k].size(), r.v[k]);
    rows.push_back(r);
  }
  return rows;
}

// a binary little-endian PLY of vertices x y z [vx vy vz] id, or of float vertices and triangle faces
struct Ply {
  std::vector<std::string> header;
  std::vector<float> xyz, vel;
  std::vector<std::uint32_t> ids, faces;
};

Ply readPly(const std::string& path) {
  const std::string bytes = readText(path);
  Ply p;
  std::size_t pos = 0, vertices = 0, faces = 0;
  bool velocity = false, id = false;
  while (true) {
    const std::size_t end = bytes.find('\n', pos);
    REQUIRE(end != std::string::npos);
    const std::string line = bytes.substr(pos, end - pos);
    pos = end + 1;
    p.header.push_back(line);
    if (line.rfind("element vertex ", 0) == 0) vertices = std::stoul(line.substr(15));
    if (line.rfind("element face ", 0) == 0) faces = std::stoul(line.substr(13));
    if (line == "property float vx") velocity = true;
    if (line == "property uint id") id = true;
    if (line == "end_header") break;
  }
  REQUIRE(p.header[0] == "ply");
  REQUIRE(p.header[1] == "format binary_little_endian 1.0");
  const auto take = [&](void* dst, std::size_t n) {
    REQUIRE(pos + n <= bytes.size());
    std::memcpy(dst, bytes.data() + pos, n);
    pos += n;
  };
  for (std::size_t v = 0; v < vertices; ++v) {
    float x[3];
    take(x, sizeof x);
    p.xyz.insert(p.xyz.end(), x, x + 3);
    if (velocity) {
      take(x, sizeof x);
      p.vel.insert(p.vel.end(), x, x + 3);
    }
    if (id) {
      std::uint32_t i = 0;
      take(&i, 4);
      p.ids.push_back(i);
    }
  }
  for (std::size_t f = 0; f < faces; ++f) {
    std::uint8_t n = 0;
    take(&n, 1);
    REQUIRE(n == 3);
    std::uint32_t t[3];
    take(t, sizeof t);
    p.faces.insert(p.faces.end(), t, t + 3);
  }
  CHECK(pos == bytes.size());
  return p;
}

// a shipped scenario with its mesh copied to `meshDir` (a folder of `dir`) and its path rewritten to
// `meshPath`, written to `dir`/`scenarioName`
void copyScenarioWithMesh(const TempDir& dir, const std::string& scenario, const std::string& shippedMesh,
                          const std::string& meshDir, const std::string& meshPath, const std::string& scenarioName) {
  fs::create_directories(dir.path() / meshDir);
  fs::copy_file(kSourceTree + "/data/" + shippedMesh, dir.path() / meshDir / fs::path(meshPath).filename());
  std::string text = readText(scenario);
  const std::string from = (scenario == kScene ? "../../data/" : "../data/") + shippedMesh;
  REQUIRE(text.find(from) != std::string::npos);
  text.replace(text.find(from), from.size(), meshPath);
  writeText(dir.file(scenarioName), text);
}

}  // namespace

TEST_CASE("Scene: tessellated spheres and boxes are closed, face outwards and lie on the shape", "[scene]") {
  const TriangleMesh s = sphereMesh({Vec3d(1, 2, 3), 0.5});
  CHECK(s.vertices.size() == 162);
  CHECK(s.triangles.size() == 320);
  CHECK(isWatertight(s));
  for (const Vec3d& v : s.vertices) CHECK(std::fabs((v - Vec3d(1, 2, 3)).norm() - 0.5) < 1e-12);
  // an inscribed polyhedron: a little less than the ball's volume, and positive (outward faces)
  const double ball = 4.0 / 3.0 * M_PI * 0.125;
  CHECK(signedVolume(s) > 0.9 * ball);
  CHECK(signedVolume(s) < ball);
  const TriangleMesh b = boxMesh({Vec3d(-1, 0, 2), Vec3d(1, 3, 2.5)});
  CHECK(b.vertices.size() == 8);
  CHECK(isWatertight(b));
  CHECK(signedVolume(b) == Approx(2.0 * 3.0 * 0.5).epsilon(1e-12));
}

TEST_CASE("Scene: the output holds every obstacle in world space and the mesh files read", "[scene]") {
  TempDir dir;
  REQUIRE(runSwarmsim("run " + shellQuote(kScene) + " -o s.h5 --quiet", dir.path()).exitCode == 0);
  const std::vector<SceneObstacle> scene = readScene(dir.file("s.h5"));
  REQUIRE(scene.size() == 3);
  CHECK(scene[0].name == "0000");
  CHECK(scene[0].type == "mesh");
  CHECK(scene[1].type == "sphere");
  CHECK(scene[2].type == "box");
  // the lamp as the scenario places it: scale 0.6, then 30 degrees about z
  MeshTransform t;
  t.scale = Vec3d::Constant(0.6);
  t.rotateDeg = Vec3d(0, 0, 30);
  const TriangleMesh lamp = loadObj(kSourceTree + "/data/street_lamp.obj", t);
  REQUIRE(scene[0].vertices.size() == 3 * lamp.vertices.size());
  REQUIRE(scene[0].faces.size() == 3 * lamp.triangles.size());
  for (std::size_t v = 0; v < lamp.vertices.size(); ++v) {
    for (int a = 0; a < 3; ++a) CHECK(scene[0].vertices[3 * v + static_cast<std::size_t>(a)] == lamp.vertices[v][a]);
  }
  CHECK(nlohmann::json::parse(scene[0].params)["file"] == kSourceTree + "/data/street_lamp.obj");
  // the ball: every vertex 0.4 m from (1.5, 1, 1); the box: its corners
  for (std::size_t v = 0; v < scene[1].vertices.size(); v += 3) {
    const Vec3d p(scene[1].vertices[v], scene[1].vertices[v + 1], scene[1].vertices[v + 2]);
    CHECK(std::fabs((p - Vec3d(1.5, 1.0, 1.0)).norm() - 0.4) < 1e-12);
  }
  CHECK(scene[2].vertices[0] == -2.0);
  CHECK(scene[2].vertices[21] == -1.2);  // corner 7 = max
  CHECK(scene[2].vertices[23] == 0.6);
  // the OBJ file's bytes, under its absolute path
  const StoredScenario st = readStoredScenario(dir.file("s.h5"));
  REQUIRE(st.inputs->embedded(kSourceTree + "/data/street_lamp.obj"));
  CHECK(*st.inputs->read(kSourceTree + "/data/street_lamp.obj", [] { return std::string(); }) ==
        readText(kSourceTree + "/data/street_lamp.obj"));
  // the stored scenario names its files by absolute path
  CHECK(st.scenario["obstacles"][0]["file"] == kSourceTree + "/data/street_lamp.obj");
}

TEST_CASE("run --from re-runs the stored scenario bit-identically, without its mesh files, from anywhere",
          "[scene][cli]") {
  TempDir dir;
  // the field model steers around the blocks: the mesh matters to every position
  copyScenarioWithMesh(dir, kSourceTree + "/scenarios/two_blocks.json", "blocks.obj", "project/meshes",
                       "meshes/blocks.obj", "project/s.json");
  REQUIRE(runSwarmsim("run project/s.json -o first.h5 --quiet --frames 8", dir.path()).exitCode == 0);
  fs::remove_all(dir.path() / "project");  // the scenario and its mesh are gone
  fs::create_directories(dir.path() / "elsewhere");
  const auto r = runSwarmsim("run --from ../first.h5 -o again.h5 --quiet", dir.path() / "elsewhere");
  INFO(r.err);
  REQUIRE(r.exitCode == 0);
  const TrajectoryInfo info = readTrajectoryInfo(dir.file("first.h5"));
  for (const char* q : {"position", "velocity"}) {
    for (const auto& s : info.swarms) {
      const std::string ds = "swarms/" + s.name + "/" + q;
      CHECK(readFloatDataset(dir.file("first.h5"), ds) == readFloatDataset(dir.file("elsewhere/again.h5"), ds));
    }
  }
  const TrajectoryInfo a = readTrajectoryInfo(dir.file("first.h5")), b = readTrajectoryInfo(dir.file("elsewhere/again.h5"));
  CHECK(b.frames == 8);
  // the same scenario, but for where it was written
  auto ja = nlohmann::json::parse(a.scenarioJson), jb = nlohmann::json::parse(b.scenarioJson);
  ja["output"].erase("path");
  jb["output"].erase("path");
  CHECK(ja == jb);
  CHECK(readScene(dir.file("first.h5")).at(0).vertices == readScene(dir.file("elsewhere/again.h5")).at(0).vertices);
  // --set and --frames apply on top; a file that is no output is refused (exit 2)
  CHECK(runSwarmsim("run --from first.h5 -o more.h5 --quiet --frames 3 --seed 9", dir.path()).exitCode == 0);
  CHECK(readTrajectoryInfo(dir.file("more.h5")).seed == 9);
  writeText(dir.file("not.h5"), "hello");
  const auto bad = runSwarmsim("run --from not.h5 -o x.h5", dir.path());
  CHECK(bad.exitCode == 2);
  CHECK(bad.err.find("not.h5") != std::string::npos);
  CHECK(runSwarmsim("run --from first.h5 " + shellQuote(kScene) + " -o x.h5", dir.path()).exitCode == 2);
}

TEST_CASE("run - reads the scenario from standard input, relative paths resolve against the working folder",
          "[scene][cli]") {
  TempDir dir;
  copyScenarioWithMesh(dir, kScene, "street_lamp.obj", "work/data", "data/lamp.obj", "s.json");
  const std::string cmd = "cd " + shellQuote(dir.file("work")) + " && " + shellQuote(kSwarmsimExe) +
                          " run - -o piped.h5 --frames 4 --json < ../s.json";
  const auto r = runCommand("sh -c " + shellQuote(cmd), dir.path());
  INFO(r.err);
  REQUIRE(r.exitCode == 0);
  const auto j = nlohmann::json::parse(r.out);  // --json: one line of JSON, nothing else
  CHECK(j["frames"] == 4);
  CHECK(j["agents"] == 550);
  CHECK(j["interrupted"] == false);
  CHECK(j["complete"] == true);
  CHECK(j["steps"] == 6);
  CHECK(j["steps_per_second"].get<double>() > 0.0);
  CHECK(j["output"] == "piped.h5");
  const TrajectoryInfo info = readTrajectoryInfo(dir.file("work/piped.h5"));
  CHECK(info.scenarioName == "scene");
  CHECK(nlohmann::json::parse(info.scenarioJson)["obstacles"][0]["file"] == dir.file("work/data/lamp.obj"));
  CHECK(readScene(dir.file("work/piped.h5")).at(0).vertices.size() == 16 * 3);
  // an error in piped JSON names <stdin> and its line
  const auto bad = runCommand("sh -c " + shellQuote("echo '{\"dt\": 0.1,' | " + shellQuote(kSwarmsimExe) +
                                                     " run - -o x.h5"),
                              dir.path());
  CHECK(bad.exitCode == 2);
  CHECK(bad.err.find("<stdin>") != std::string::npos);
}

TEST_CASE("Output paths that lead to a pipe, a device or a FIFO are refused with exit 3, never replaced",
          "[scene][cli][safety]") {
  TempDir dir;
  // /dev/stdout when standard output is a pipe (links followed by the kernel: /proc/self/fd/1 -> pipe)
  const auto piped = runCommand("sh -c " + shellQuote(shellQuote(kSwarmsimExe) + " run " + shellQuote(kScene) +
                                                        " -o /dev/stdout --force | cat"),
                                dir.path());
  CHECK(piped.err.find("FIFO") != std::string::npos);
  CHECK(piped.out.empty());
  // the exit code, with a pipe as standard input: /proc/self/fd/0 leads to it
  const auto st = runCommand("sh -c " + shellQuote("true | " + shellQuote(kSwarmsimExe) + " run " + shellQuote(kScene) +
                                                   " -o /proc/self/fd/0 --force"),
                             dir.path());
  CHECK(st.exitCode == 3);
  CHECK(st.err.find("is a FIFO") != std::string::npos);
  REQUIRE(mkfifo(dir.file("fifo").c_str(), 0600) == 0);
  fs::create_symlink(dir.file("fifo"), dir.file("link"));
  fs::create_symlink("/dev/null", dir.file("null"));
  for (const char* target : {"fifo", "link", "null"}) {
    const auto r = runSwarmsim("run " + shellQuote(kScene) + " -o " + target + " --force", dir.path());
    INFO(target << ": " << r.err);
    CHECK(r.exitCode == 3);
  }
  CHECK(fs::is_fifo(dir.file("fifo")));
  CHECK(fs::is_symlink(dir.file("null")));
  CHECK(fs::is_character_file("/dev/null"));
  // export: the same rules for every file it writes
  REQUIRE(runSwarmsim("run " + shellQuote(kScene) + " -o s.h5 --quiet --frames 3", dir.path()).exitCode == 0);
  for (const char* format : {"csv", "xdmf"}) {
    for (const char* target : {"fifo", "link", "null"}) {
      const std::string to = std::string(format) == "xdmf" ? std::string(target) + ".xmf2" : target;
      if (to != target) fs::create_symlink(target, dir.file(to));  // a link with the extension, to the same thing
      const auto r = runSwarmsim(std::string("export s.h5 --format ") + format + " -o " + to + " --force", dir.path());
      INFO(format << " " << target << ": " << r.err);
      CHECK(r.exitCode == 3);
    }
  }
  CHECK(fs::is_fifo(dir.file("fifo")));
  // a file swarmsim did not write is not replaced, even with --force; its own export is
  writeText(dir.file("notes.csv"), "my notes\n");
  CHECK(runSwarmsim("export s.h5 --format csv -o notes.csv --force", dir.path()).exitCode == 3);
  CHECK(readText(dir.file("notes.csv")) == "my notes\n");
  CHECK(runSwarmsim("export s.h5 --format csv -o out.csv --quiet", dir.path()).exitCode == 0);
  CHECK(runSwarmsim("export s.h5 --format csv -o out.csv --quiet", dir.path()).exitCode == 3);
  CHECK(runSwarmsim("export s.h5 --format csv -o out.csv --quiet --force", dir.path()).exitCode == 0);
  // nothing half-written is left beside the outputs
  for (const auto& e : dir.entries()) CHECK(e.find(".part") == std::string::npos);
}

TEST_CASE("export csv: one row per agent and frame, values that read back exactly, to a file or stdout",
          "[export]") {
  TempDir dir;
  REQUIRE(runSwarmsim("run " + shellQuote(kScene) + " -o s.h5 --quiet", dir.path()).exitCode == 0);
  REQUIRE(runSwarmsim("export s.h5 --format csv --quiet", dir.path()).exitCode == 0);
  const std::string text = readText(dir.file("s.csv"));
  std::string header;
  const std::vector<CsvRow> rows = parseCsv(text, header);
  CHECK(header == "frame,time,swarm,id,x,y,z,vx,vy,vz");
  const TrajectoryInfo info = readTrajectoryInfo(dir.file("s.h5"));
  REQUIRE(rows.size() == static_cast<std::size_t>(info.frames) * 550);
  const std::vector<double> time = readDoubleDataset(dir.file("s.h5"), "time");
  std::map<std::string, std::pair<std::vector<float>, std::vector<float>>> data;
  for (const char* s : {"midges", "gnats"}) {
    data[s] = {readFloatDataset(dir.file("s.h5"), std::string("swarms/") + s + "/position"),
               readFloatDataset(dir.file("s.h5"), std::string("swarms/") + s + "/velocity")};
  }
  std::size_t k = 0;
  for (long long f = 0; f < info.frames; ++f) {
    for (const auto& [swarm, agents] : {std::pair<std::string, std::size_t>{"midges", 400}, {"gnats", 150}}) {
      for (std::size_t a = 0; a < agents; ++a, ++k) {
        const CsvRow& r = rows[k];
        REQUIRE(r.frame == f);
        REQUIRE(r.time == time[static_cast<std::size_t>(f)]);
        REQUIRE(r.swarm == swarm);
        REQUIRE(r.id == a);
        const std::size_t at = 3 * (agents * static_cast<std::size_t>(f) + a);
        for (int c = 0; c < 3; ++c) {
          REQUIRE(r.v[c] == data[swarm].first[at + static_cast<std::size_t>(c)]);
          REQUIRE(r.v[3 + c] == data[swarm].second[at + static_cast<std::size_t>(c)]);
        }
      }
    }
  }
  // standard output gives the same bytes; --frames and --swarm select
  const auto piped = runSwarmsim("export s.h5 --format csv -o -", dir.path());
  REQUIRE(piped.exitCode == 0);
  CHECK(piped.out == text);
  const auto part = runSwarmsim("export s.h5 --format csv -o - --frames 5:8 --swarm gnats", dir.path());
  REQUIRE(part.exitCode == 0);
  const std::vector<CsvRow> some = parseCsv(part.out, header);
  REQUIRE(some.size() == 3 * 150);
  CHECK(some.front().frame == 5);
  CHECK(some.back().frame == 7);
  for (const CsvRow& r : some) CHECK(r.swarm == "gnats");
  CHECK(runSwarmsim("export s.h5 --format csv -o - --swarm nobody", dir.path()).exitCode == 2);
  CHECK(runSwarmsim("export s.h5 --format csv -o - --frames 90:99", dir.path()).exitCode == 2);
  CHECK(runSwarmsim("export nothere.h5 --format csv", dir.path()).exitCode == 2);
}

TEST_CASE("export csv: rows formatted in parallel blocks are the serial text, in agent order", "[export]") {
  // 70,150 agents: two blocks of the first swarm (65,536 agents each), each split across the threads
  TempDir dir;
  REQUIRE(runSwarmsim("run " + shellQuote(kScene) + " -o s.h5 --quiet --frames 2 --set 'swarms[0].count=70000'",
                      dir.path()).exitCode == 0);
  const auto one = runCommand("cd " + shellQuote(dir.path().string()) + " && OMP_NUM_THREADS=1 " +
                                  shellQuote(kSwarmsimExe) + " export s.h5 --format csv -o -",
                              dir.path());
  const auto two = runCommand("cd " + shellQuote(dir.path().string()) + " && OMP_NUM_THREADS=2 " +
                                  shellQuote(kSwarmsimExe) + " export s.h5 --format csv -o -",
                              dir.path());
  REQUIRE(one.exitCode == 0);
  REQUIRE(two.exitCode == 0);
  CHECK(one.out == two.out);
  std::string header;
  const std::vector<CsvRow> rows = parseCsv(two.out, header);
  REQUIRE(rows.size() == 2u * 70150u);  // frames 0 and 1
  const std::vector<float> pos = readFloatDataset(dir.file("s.h5"), "swarms/midges/position");
  // each frame: the midges in id order, then the gnats (counted, not asserted row by row: a sanitized build
  // spends minutes on 140,000 REQUIREs)
  std::size_t wrong = 0, firstWrong = rows.size();
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const std::size_t f = k / 70150, a = k % 70150;
    const bool ok = rows[k].frame == static_cast<long long>(f) &&
                    (a < 70000 ? rows[k].swarm == "midges" && rows[k].id == a && rows[k].v[0] == pos[3 * (70000 * f + a)]
                               : rows[k].swarm == "gnats" && rows[k].id == a - 70000);
    if (!ok) {
      ++wrong;
      firstWrong = std::min(firstWrong, k);
    }
  }
  INFO("first wrong row: " << firstWrong);
  CHECK(wrong == 0);
}

TEST_CASE("export csv leaves absent agents out, ply files hold only the present ones", "[export]") {
  TempDir dir;
  const auto r = runSwarmsim("run " + shellQuote(kSourceTree + "/scenarios/fastswarm_mixing.json") +
                                 " -o m.h5 --quiet --frames 40 --set swarms[1].count=10",
                             dir.path());
  INFO(r.err);
  REQUIRE(r.exitCode == 0);
  const TrajectoryInfo info = readTrajectoryInfo(dir.file("m.h5"));
  std::string replayed;
  for (const auto& s : info.swarms) {
    if (s.model == "replay") replayed = s.name;
  }
  REQUIRE(!replayed.empty());
  std::vector<std::uint64_t> shape;
  const std::vector<float> pos = readFloatDataset(dir.file("m.h5"), "swarms/" + replayed + "/position", &shape);
  std::size_t present = 0, absent = 0;
  for (std::size_t i = 0; i < pos.size(); i += 3) (std::isfinite(pos[i]) ? present : absent) += 1;
  REQUIRE(absent > 0);  // the excerpt has insects entering and leaving
  const auto csv = runSwarmsim("export m.h5 --format csv -o - --swarm " + replayed, dir.path());
  REQUIRE(csv.exitCode == 0);
  CHECK(static_cast<std::size_t>(std::count(csv.out.begin(), csv.out.end(), '\n')) == present + 1);
  CHECK(csv.out.find("nan") == std::string::npos);
  REQUIRE(runSwarmsim("export m.h5 --format ply -o ply --quiet --swarm " + replayed, dir.path()).exitCode == 0);
  std::size_t points = 0;
  for (std::uint64_t f = 0; f < shape[0]; ++f) {
    char name[64];
    std::snprintf(name, sizeof name, "ply/%s.%04llu.ply", replayed.c_str(), static_cast<unsigned long long>(f));
    const Ply p = readPly(dir.file(name));
    points += p.ids.size();
    for (std::size_t i = 0; i < p.ids.size(); ++i) {
      CHECK(pos[3 * (shape[1] * f + p.ids[i])] == p.xyz[3 * i]);
    }
  }
  CHECK(points == present);
}

TEST_CASE("export ply: a binary point cloud per swarm and frame that reads back as the .h5, and the obstacles",
          "[export]") {
  TempDir dir;
  REQUIRE(runSwarmsim("run " + shellQuote(kScene) + " -o s.h5 --quiet", dir.path()).exitCode == 0);
  REQUIRE(runSwarmsim("export s.h5 --format ply --frames 10: --quiet", dir.path()).exitCode == 0);
  // frames 10..23 of both swarms, plus obstacles.ply; numbers as in the .h5
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir.path() / "s_ply")) files.push_back(e.path().filename().string());
  CHECK(files.size() == 2 * 14 + 1);
  CHECK(!fs::exists(dir.path() / "s_ply" / "midges.0009.ply"));
  for (const char* swarm : {"midges", "gnats"}) {
    std::vector<std::uint64_t> shape;
    const auto pos = readFloatDataset(dir.file("s.h5"), std::string("swarms/") + swarm + "/position", &shape);
    const auto vel = readFloatDataset(dir.file("s.h5"), std::string("swarms/") + swarm + "/velocity");
    for (std::size_t f : {10, 17, 23}) {
      char name[64];
      std::snprintf(name, sizeof name, "s_ply/%s.%04zu.ply", swarm, f);
      const Ply p = readPly(dir.file(name));
      CHECK(p.xyz == frameOf(pos, shape[1], f));
      CHECK(p.vel == frameOf(vel, shape[1], f));
      REQUIRE(p.ids.size() == shape[1]);
      for (std::size_t i = 0; i < p.ids.size(); ++i) CHECK(p.ids[i] == i);
      CHECK(std::find(p.header.begin(), p.header.end(),
                      "comment swarmsim export: swarm " + std::string(swarm) + " frame " + std::to_string(f) +
                          " time " + (f == 10 ? "0.4" : f == 17 ? "0.68" : "0.92")) != p.header.end());
    }
  }
  const Ply ob = readPly(dir.file("s_ply/obstacles.ply"));
  const std::vector<SceneObstacle> scene = readScene(dir.file("s.h5"));
  std::size_t nv = 0, nf = 0;
  for (const auto& s : scene) {
    nv += s.vertices.size() / 3;
    nf += s.faces.size() / 3;
  }
  CHECK(ob.xyz.size() == 3 * nv);
  CHECK(ob.faces.size() == 3 * nf);
  CHECK(ob.xyz[3 * 16] == static_cast<float>(scene[1].vertices[0]));  // the ball's first vertex follows the lamp's 16
  CHECK(ob.faces[3 * 28] == scene[1].faces[0] + 16);
  // again without --force: refused, nothing changed; with it, replaced
  CHECK(runSwarmsim("export s.h5 --format ply --frames 10:", dir.path()).exitCode == 3);
  CHECK(runSwarmsim("export s.h5 --format ply --frames 10: --force --quiet", dir.path()).exitCode == 0);
  CHECK(runSwarmsim("export s.h5 --format ply -o -", dir.path()).exitCode == 2);
}

TEST_CASE("export xdmf: the .xmf points into the .h5 for every frame, swarm and obstacle", "[export]") {
  TempDir dir;
  REQUIRE(runSwarmsim("run " + shellQuote(kScene) + " -o s.h5 --quiet", dir.path()).exitCode == 0);
  // the default: s.xmf2, for ParaView's XDMF Reader (a frame is an XML HyperSlab of the dataset)
  REQUIRE(runSwarmsim("export s.h5 --format xdmf --quiet --frames 2:6", dir.path()).exitCode == 0);
  const std::string h5 = fs::weakly_canonical(dir.file("s.h5")).string();
  for (const char* name : {"s.xmf2", "s.xmf"}) {
    if (std::string(name) == "s.xmf") {
      REQUIRE(runSwarmsim("export s.h5 --format xdmf --quiet --frames 2:6 -o s.xmf", dir.path()).exitCode == 0);
    }
    const std::string x = readText(dir.file(name));
    INFO(name);
    const auto count = [&](const std::string& what) {
      std::size_t n = 0;
      for (std::size_t p = x.find(what); p != std::string::npos; p = x.find(what, p + 1)) ++n;
      return n;
    };
    CHECK(count("<Time Value=") == 4);
    CHECK(count("TopologyType=\"Polyvertex\"") == 8);
    CHECK(count("TopologyType=\"Triangle\"") == 12);
    CHECK(x.find(h5 + ":/scene/obstacles/0001/faces") != std::string::npos);
    CHECK(x.find("<Time Value=\"0.08\"/>") != std::string::npos);
    CHECK(x.find(h5 + ":/swarms/gnats/swarm_index") != std::string::npos);
    if (std::string(name) == "s.xmf") {  // the Xdmf3 reader's start:stride:count:dims
      CHECK(x.find(h5 + ":/swarms/midges/position|2 0 0:1 1 1:1 400 3:24 400 3") != std::string::npos);
      CHECK(x.find(h5 + ":/swarms/gnats/velocity|5 0 0:1 1 1:1 150 3:24 150 3") != std::string::npos);
    } else {
      CHECK(x.find("Format=\"XML\">2 0 0 1 1 1 1 400 3</DataItem><DataItem Dimensions=\"24 400 3\" NumberType=\"Float\" "
                   "Precision=\"4\" Format=\"HDF\">" + h5 + ":/swarms/midges/position") != std::string::npos);
      CHECK(count("ItemType=\"HyperSlab\"") == 16);
    }
  }
  REQUIRE(runSwarmsim("export s.h5 --format xdmf --relative -o sub/r.xmf2 --quiet", dir.path()).exitCode == 0);
  CHECK(readText(dir.file("sub/r.xmf2")).find(">../s.h5:/swarms/midges/position</DataItem>") != std::string::npos);
  // another extension is refused: neither reader would open it
  CHECK(runSwarmsim("export s.h5 --format xdmf -o s.xml", dir.path()).exitCode == 2);
}

TEST_CASE("CLI: an unknown subcommand is one swarmsim error line naming it, exit 2", "[cli]") {
  TempDir dir;
  const auto r = runSwarmsim("frobnicate x.json", dir.path());
  CHECK(r.exitCode == 2);
  CHECK(r.err.rfind("swarmsim: error: unknown subcommand \"frobnicate\"", 0) == 0);
  CHECK(std::count(r.err.begin(), r.err.end(), '\n') == 1);
}
