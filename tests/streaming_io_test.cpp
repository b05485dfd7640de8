// Bounded-memory writing: the trajectory writer transfers position and
// velocity rows in blocks, the checkpoint is streamed from the live states and
// hashed in pieces. None of it may change a byte: a file's bytes and data hash
// do not depend on the block size, a streamed checkpoint is the encoding that
// was once built in memory, and ByteHasher over pieces is hashBytes.
#include <algorithm>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include <catch2/catch.hpp>

#include "core/state_buffer.hpp"
#include "io/checkpoint.hpp"
#include "io/scenario.hpp"
#include "io/trajectory_reader.hpp"
#include "io/trajectory_writer.hpp"
#include "run.hpp"
#include "test_util.hpp"

using swarmsim::Json;
using swarmsim::SwarmState;
using swarmsim::TrajectoryWriter;
using swarmsim_test::TempDir;

namespace {

std::vector<unsigned char> randomBytes(std::mt19937_64& rng, std::size_t n) {
  std::vector<unsigned char> v(n);
  for (auto& b : v) b = static_cast<unsigned char>(rng());
  return v;
}

std::vector<SwarmState> spawnAll(const swarmsim::Scenario& sc) {
  std::vector<SwarmState> swarms;
  for (std::uint32_t s = 0; s < sc.swarms.size(); ++s) swarms.push_back(swarmsim::spawnSwarm(sc.swarms[s], sc.seed, s));
  return swarms;
}

// the agents of `s` in another order (ids move with them)
SwarmState shuffled(const SwarmState& s, std::uint64_t seed) {
  std::vector<std::size_t> order(s.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::shuffle(order.begin(), order.end(), std::mt19937_64(seed));
  SwarmState out;
  out.name = s.name;
  out.resizeStorage(s.size());
  for (std::size_t a = 0; a < s.size(); ++a) {
    const std::size_t b = order[a];
    out.setPosition(a, s.position(b));
    out.setVelocity(a, s.velocity(b));
    out.id[a] = s.id[b];
  }
  return out;
}

// swarms "a" (shuffled) and "b" (in id order), 3 frames, 2 statistics on "a"
Json writerScenario(std::int64_t countA, int compression) {
  Json j = Json::parse(R"({
    "name": "blocks", "seed": 99, "dt": 0.01, "frames": 3, "steps_per_frame": 1,
    "domain": {"min": [-5, -5, -5], "max": [5, 5, 5]},
    "swarms": [
      {"name": "a", "count": 10, "model": "boids", "initial_speed": 0.4,
       "spawn": {"type": "sphere", "center": [0, 0, 0], "radius": 2}},
      {"name": "b", "count": 333, "model": "boids", "initial_speed": 0.2,
       "spawn": {"type": "box", "min": [-1, -1, -1], "max": [1, 1, 1]}}
    ]
  })");
  j["swarms"][0]["count"] = countA;
  j["output"] = {{"compression", compression}};
  return j;
}

struct Written {
  std::uint64_t hash = 0;
  std::uint64_t storedHash = 0;  // hashStoredFrames, read back before closing
};

// 3 frames of the scenario's swarms, transferred in blocks of at most maxRows rows (0: the default)
Written writeFrames(const swarmsim::Scenario& sc, const std::string& path, std::size_t maxRows) {
  std::vector<SwarmState> swarms = spawnAll(sc);
  swarms[0] = shuffled(swarms[0], 5);
  TrajectoryWriter w(path, sc, swarms, {{"mean", "spread"}, {}}, TrajectoryWriter::Mode::kCreate);
  if (maxRows > 0) w.setMaxBlockRows(maxRows);
  for (int f = 0; f < 3; ++f) {
    w.writeFrame(0.01 * f, swarms, {{1.5 * f, -0.25 * f}, {}});
    for (auto& s : swarms) {
      for (std::size_t a = 0; a < s.size(); ++a) s.setPosition(a, s.position(a) + s.velocity(a) * 0.1f);
    }
    swarms[0] = shuffled(swarms[0], 17 + static_cast<std::uint64_t>(f));
  }
  Written r;
  r.hash = w.dataHash();
  r.storedHash = w.hashStoredFrames(3);
  w.close(true);
  return r;
}

const char* const kDatasets[] = {"swarms/a/position", "swarms/a/velocity", "swarms/b/position", "swarms/b/velocity"};

// the checkpoint encoding as writeCheckpoint built it in memory before it was
// streamed: one StateOut body, then hashBytes of it
std::string inMemoryEncoding(const swarmsim::CheckpointView& c) {
  constexpr char kMagic[16] = "swarmsim-ckpt\n";
  swarmsim::StateOut out;
  for (char ch : kMagic) out.put(ch);
  out.put(std::uint32_t{1});
  out.putString(c.scenario);
  out.put(c.step);
  out.put(c.frames);
  out.put(c.dataHash);
  out.put<std::uint32_t>(static_cast<std::uint32_t>(c.swarms.size()));
  for (const SwarmState* s : c.swarms) {
    out.putString(s->name);
    for (const auto* a : {&s->px, &s->py, &s->pz, &s->vx, &s->vy, &s->vz}) out.putVector(*a);
    out.putVector(s->id);
  }
  out.put<std::uint32_t>(static_cast<std::uint32_t>(c.modelStates.size()));
  for (const auto& m : c.modelStates) out.putString(m);
  std::string all = out.bytes();
  const std::uint64_t sum = swarmsim::hashBytes(all.data(), all.size(), 0);
  all.append(reinterpret_cast<const char*>(&sum), sizeof sum);
  return all;
}

}  // namespace

TEST_CASE("hashBytes keeps its values", "[io][checkpoint]") {
  // the data hashes of existing outputs and checkpoints were made with these
  std::vector<unsigned char> v(100);
  for (std::size_t i = 0; i < v.size(); ++i) v[i] = static_cast<unsigned char>(i * 7 + 3);
  CHECK(swarmsim::hashBytes(v.data(), 0, 0) == 0x9ca066f1a4ab2eeaULL);
  CHECK(swarmsim::hashBytes(v.data(), 15, 0) == 0xf5feee3ed4ec9f53ULL);
  CHECK(swarmsim::hashBytes(v.data(), 17, 0x123456789abcdefULL) == 0xad76f087c613ff42ULL);
  CHECK(swarmsim::hashBytes(v.data(), 100, 0) == 0xfb00e5749f8c32a2ULL);
  CHECK(swarmsim::hashBytes(v.data(), 100, 0x123456789abcdefULL) == 0x059cb6982a119858ULL);
}

TEST_CASE("ByteHasher over any split of the bytes is hashBytes of them", "[io][checkpoint]") {
  std::mt19937_64 rng(2024);
  for (int trial = 0; trial < 500; ++trial) {
    const std::size_t n = trial < 400 ? rng() % 100 : rng() % 5000;
    const std::vector<unsigned char> bytes = randomBytes(rng, n);
    const std::uint64_t h = trial % 2 == 0 ? 0 : rng();
    const std::uint64_t whole = swarmsim::hashBytes(bytes.data(), n, h);
    // cut at random points (empty pieces included)
    std::vector<std::size_t> cuts = {0, n};
    const std::size_t pieces = rng() % 12;
    for (std::size_t i = 0; i < pieces; ++i) cuts.push_back(n == 0 ? 0 : rng() % (n + 1));
    std::sort(cuts.begin(), cuts.end());
    swarmsim::ByteHasher hasher(h, n);
    for (std::size_t i = 0; i + 1 < cuts.size(); ++i) hasher.update(bytes.data() + cuts[i], cuts[i + 1] - cuts[i]);
    INFO("trial " << trial << ", " << n << " bytes in " << cuts.size() - 1 << " pieces");
    REQUIRE(hasher.finish() == whole);
  }
  // the hash sees every byte and the chained value
  std::vector<unsigned char> bytes = randomBytes(rng, 37);
  const std::uint64_t h0 = swarmsim::hashBytes(bytes.data(), bytes.size(), 0);
  CHECK(swarmsim::hashBytes(bytes.data(), bytes.size(), 1) != h0);
  bytes[33] ^= 1;
  CHECK(swarmsim::hashBytes(bytes.data(), bytes.size(), 0) != h0);
  // fewer bytes than announced would give a hash that matches nothing
  swarmsim::ByteHasher shortOne(0, 10);
  shortOne.update(bytes.data(), 9);
  CHECK_THROWS_AS(shortOne.finish(), std::logic_error);
}

TEST_CASE("Trajectory writer: the file does not depend on the block size", "[io][writer]") {
  TempDir dir;
  const swarmsim::Scenario sc = swarmsim::parseScenario(writerScenario(1000, 0), dir.file("s.json"));
  const std::string ref = dir.file("ref.h5");
  const Written w0 = writeFrames(sc, ref, 0);
  CHECK(w0.storedHash == w0.hash);
  const std::string refBytes = swarmsim_test::readText(ref);
  // row r of every frame is agent id r: frame 0 is the spawned state
  const SwarmState a0 = swarmsim::spawnSwarm(sc.swarms[0], sc.seed, 0);
  const std::vector<float> pos = swarmsim::readFloatDataset(ref, "swarms/a/position");
  REQUIRE(pos.size() == 3 * 3 * a0.size());
  for (std::size_t r = 0; r < a0.size(); ++r) {
    REQUIRE(pos[3 * r] == a0.px[r]);
    REQUIRE(pos[3 * r + 2] == a0.pz[r]);
  }
  for (const std::size_t rows : {std::size_t{1}, std::size_t{7}, std::size_t{100}, std::size_t{999}}) {
    INFO(rows << " rows per block");
    const std::string path = dir.file("blocks" + std::to_string(rows) + ".h5");
    const Written w = writeFrames(sc, path, rows);
    CHECK(w.hash == w0.hash);
    CHECK(w.storedHash == w0.hash);
    CHECK(swarmsim_test::readText(path) == refBytes);
  }
  SECTION("frames copied in blocks are the same file") {
    const std::string copy = dir.file("copy.h5");
    TrajectoryWriter w(copy, sc, spawnAll(sc), {{"mean", "spread"}, {}}, TrajectoryWriter::Mode::kCreate);
    w.setMaxBlockRows(7);
    w.copyFramesFrom(ref, 3);
    CHECK(w.dataHash() == w0.hash);
    w.close(true);
    CHECK(swarmsim_test::readText(copy) == refBytes);
  }
}

TEST_CASE("Trajectory writer: compressed chunks written in blocks", "[io][writer]") {
  TempDir dir;
  SECTION("blocks of whole chunks give the same file") {
    // 200,000 agents: chunks of 87,381 rows; blocks of 100,000 rows become blocks of one chunk
    const swarmsim::Scenario sc = swarmsim::parseScenario(writerScenario(200000, 4), dir.file("s.json"));
    const Written w0 = writeFrames(sc, dir.file("ref.h5"), 0);
    const Written w1 = writeFrames(sc, dir.file("chunks.h5"), 100000);
    CHECK(w1.hash == w0.hash);
    CHECK(w1.storedHash == w0.hash);
    CHECK(swarmsim_test::readText(dir.file("chunks.h5")) == swarmsim_test::readText(dir.file("ref.h5")));
  }
  SECTION("blocks smaller than a chunk hold the same data") {
    // a chunk written in pieces is compressed again each time: other bytes, the same values
    const swarmsim::Scenario sc = swarmsim::parseScenario(writerScenario(1000, 4), dir.file("s.json"));
    const Written w0 = writeFrames(sc, dir.file("ref.h5"), 0);
    const Written w1 = writeFrames(sc, dir.file("small.h5"), 7);
    CHECK(w1.hash == w0.hash);
    CHECK(w1.storedHash == w0.hash);
    for (const char* d : kDatasets) {
      CHECK(swarmsim::readFloatDataset(dir.file("small.h5"), d) == swarmsim::readFloatDataset(dir.file("ref.h5"), d));
    }
  }
}

TEST_CASE("Checkpoint written streaming is the in-memory encoding", "[io][checkpoint]") {
  TempDir dir;
  // a swarm larger than the 4 MiB write buffer, so that it is cut at odd places
  SwarmState big, small, empty;
  big.name = "big";
  big.resize(200003);
  std::mt19937_64 rng(7);
  for (auto* a : {&big.px, &big.py, &big.pz, &big.vx, &big.vy, &big.vz}) {
    for (float& x : *a) x = static_cast<float>(rng() % 100000) * 0.001f;
  }
  std::shuffle(big.id.begin(), big.id.end(), rng);
  small.name = "s";
  small.resize(3);
  small.px = {1.0f, 2.0f, 3.0f};
  empty.name = "nothing";
  swarmsim::CheckpointView c;
  c.scenario = R"({"name": "odd-length scenario text"})";
  c.step = 123456789;
  c.frames = 42;
  c.dataHash = 0xfeedface12345678ULL;
  c.swarms = {&big, &small, &empty};
  const std::vector<unsigned char> modelBytes = randomBytes(rng, 1001);
  c.modelStates = {std::string(modelBytes.begin(), modelBytes.end()), "", "x"};

  const std::string path = dir.file(".out.h5.ckpt");
  swarmsim::writeCheckpoint(path, c);
  const std::string expected = inMemoryEncoding(c);
  CHECK(expected.size() > (std::size_t{4} << 20));
  CHECK(swarmsim_test::readText(path) == expected);
  CHECK(dir.entries() == std::vector<std::string>{".out.h5.ckpt"});  // no temporary file left

  const swarmsim::Checkpoint back = swarmsim::readCheckpoint(path);
  CHECK(back.step == c.step);
  CHECK(back.frames == c.frames);
  CHECK(back.dataHash == c.dataHash);
  REQUIRE(back.swarms.size() == 3);
  CHECK(back.swarms[0].px == big.px);
  CHECK(back.swarms[0].vz == big.vz);
  CHECK(back.swarms[0].id == big.id);
  CHECK(back.swarms[1].px == small.px);
  CHECK(back.swarms[2].size() == 0);
  CHECK(back.modelStates == c.modelStates);

  // written again from what was read: the same file
  swarmsim::CheckpointView again = c;
  again.swarms = {&back.swarms[0], &back.swarms[1], &back.swarms[2]};
  again.modelStates = back.modelStates;
  swarmsim::writeCheckpoint(path, again);
  CHECK(swarmsim_test::readText(path) == expected);
}
