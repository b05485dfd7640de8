#include "io/checkpoint.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/error.hpp"
#include "core/state_buffer.hpp"

namespace swarmsim {

namespace {

constexpr char kMagic[16] = "swarmsim-ckpt\n";
constexpr std::uint32_t kVersion = 1;

inline std::uint64_t mix(std::uint64_t x) {
  x ^= x >> 33;
  x *= 0xff51afd7ed558ccdULL;
  x ^= x >> 33;
  x *= 0xc4ceb9fe1a85ec53ULL;
  x ^= x >> 33;
  return x;
}

void writeAll(int fd, const char* data, std::size_t size, const std::string& path) {
  while (size > 0) {
    const ssize_t w = ::write(fd, data, size);
    if (w < 0) {
      if (errno == EINTR) continue;
      throw OutputError(path + ": cannot write checkpoint: " + std::strerror(errno));
    }
    data += w;
    size -= static_cast<std::size_t>(w);
  }
}

}  // namespace

std::uint64_t hashBytes(const void* data, std::size_t size, std::uint64_t h) {
  const auto* p = static_cast<const unsigned char*>(data);
  std::uint64_t a = h ^ 0x9e3779b97f4a7c15ULL, b = h + size;
  std::size_t i = 0;
  for (; i + 16 <= size; i += 16) {
    std::uint64_t w0, w1;
    std::memcpy(&w0, p + i, 8);
    std::memcpy(&w1, p + i + 8, 8);
    a = (a ^ w0) * 0x9fb21c651e98df25ULL;
    b = (b ^ w1) * 0xc2b2ae3d27d4eb4fULL;
    a = (a << 29) | (a >> 35);
    b = (b << 31) | (b >> 33);
  }
  for (; i < size; ++i) a = (a ^ p[i]) * 0x100000001b3ULL;
  return mix(a ^ mix(b));
}

void writeCheckpoint(const std::string& path, const Checkpoint& c) {
  StateOut out;
  for (char ch : kMagic) out.put(ch);
  out.put(kVersion);
  out.putString(c.scenario);
  out.put(c.step);
  out.put(c.frames);
  out.put(c.dataHash);
  out.put<std::uint32_t>(static_cast<std::uint32_t>(c.swarms.size()));
  for (const SwarmState& s : c.swarms) {
    out.putString(s.name);
    for (const auto* a : {&s.px, &s.py, &s.pz, &s.vx, &s.vy, &s.vz}) out.putVector(*a);
    out.putVector(s.id);
  }
  out.put<std::uint32_t>(static_cast<std::uint32_t>(c.modelStates.size()));
  for (const auto& m : c.modelStates) out.putString(m);
  const std::string& body = out.bytes();
  const std::uint64_t sum = hashBytes(body.data(), body.size(), 0);

  const std::string tmp = path + ".new";
  ::unlink(tmp.c_str());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd < 0) throw OutputError(tmp + ": cannot create checkpoint: " + std::strerror(errno));
  try {
    writeAll(fd, body.data(), body.size(), tmp);
    writeAll(fd, reinterpret_cast<const char*>(&sum), sizeof sum, tmp);
    if (::fsync(fd) != 0) throw OutputError(tmp + ": cannot sync checkpoint: " + std::strerror(errno));
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  ::close(fd);
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    throw OutputError(path + ": cannot rename checkpoint into place: " + std::strerror(err));
  }
  // the rename itself reaches the disk with the folder
  const std::string dir = std::filesystem::path(path).has_parent_path()
                              ? std::filesystem::path(path).parent_path().string()
                              : std::string(".");
  const int dfd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dfd >= 0) {
    ::fsync(dfd);
    ::close(dfd);
  }
}

Checkpoint readCheckpoint(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f) throw InputError(path + ": cannot open checkpoint");
  std::ostringstream buf;
  buf << f.rdbuf();
  const std::string all = buf.str();
  const auto bad = [&](const std::string& why) { return InputError(path + ": not a usable checkpoint: " + why); };
  if (all.size() < sizeof kMagic + 8 || std::memcmp(all.data(), kMagic, sizeof kMagic) != 0) {
    throw bad("not a swarmsim checkpoint");
  }
  const std::string body = all.substr(0, all.size() - 8);
  std::uint64_t sum = 0;
  std::memcpy(&sum, all.data() + body.size(), 8);
  if (hashBytes(body.data(), body.size(), 0) != sum) throw bad("checksum mismatch (torn or damaged file)");
  Checkpoint c;
  try {
    StateIn in(body);
    for (std::size_t i = 0; i < sizeof kMagic; ++i) in.get<char>();
    const auto version = in.get<std::uint32_t>();
    if (version != kVersion) throw bad("format version " + std::to_string(version) + ", expected " + std::to_string(kVersion));
    c.scenario = in.getString();
    c.step = in.get<std::uint64_t>();
    c.frames = in.get<std::int64_t>();
    c.dataHash = in.get<std::uint64_t>();
    const auto swarms = in.get<std::uint32_t>();
    for (std::uint32_t k = 0; k < swarms; ++k) {
      SwarmState s;
      s.name = in.getString();
      for (auto* a : {&s.px, &s.py, &s.pz, &s.vx, &s.vy, &s.vz}) *a = in.getVector<float>();
      s.id = in.getVector<std::uint32_t>();
      const std::size_t n = s.px.size();
      for (const auto* a : {&s.py, &s.pz, &s.vx, &s.vy, &s.vz}) {
        if (a->size() != n) throw bad("swarm arrays of different lengths");
      }
      if (s.id.size() != n) throw bad("swarm arrays of different lengths");
      c.swarms.push_back(std::move(s));
    }
    const auto models = in.get<std::uint32_t>();
    for (std::uint32_t k = 0; k < models; ++k) c.modelStates.push_back(in.getString());
    if (!in.atEnd()) throw bad("trailing data");
  } catch (const std::runtime_error& e) {
    if (dynamic_cast<const InputError*>(&e)) throw;
    throw bad(e.what());
  }
  return c;
}

}  // namespace swarmsim
