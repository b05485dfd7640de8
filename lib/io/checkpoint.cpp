#include "io/checkpoint.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>
#include <vector>

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

// 16 bytes into the hash state
inline void addWord(std::uint64_t& a, std::uint64_t& b, const unsigned char* p) {
  std::uint64_t w0, w1;
  std::memcpy(&w0, p, 8);
  std::memcpy(&w1, p + 8, 8);
  a = (a ^ w0) * 0x9fb21c651e98df25ULL;
  b = (b ^ w1) * 0xc2b2ae3d27d4eb4fULL;
  a = (a << 29) | (a >> 35);
  b = (b << 31) | (b >> 33);
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

ByteHasher::ByteHasher(std::uint64_t h, std::size_t size) : a_(h ^ 0x9e3779b97f4a7c15ULL), b_(h + size), size_(size) {}

void ByteHasher::update(const void* data, std::size_t n) {
  if (n == 0) return;  // (data may be null then)
  const auto* p = static_cast<const unsigned char*>(data);
  seen_ += n;
  // the state in locals: stores to members could alias the bytes read
  std::uint64_t a = a_, b = b_;
  if (partSize_ > 0) {
    const std::size_t take = std::min(n, sizeof part_ - partSize_);
    std::memcpy(part_ + partSize_, p, take);
    partSize_ += take;
    p += take;
    n -= take;
    if (partSize_ < sizeof part_) return;
    partSize_ = 0;
    addWord(a, b, part_);
  }
  for (; n >= 16; p += 16, n -= 16) addWord(a, b, p);
  std::memcpy(part_, p, n);
  partSize_ = n;
  a_ = a;
  b_ = b;
}

std::uint64_t ByteHasher::finish() const {
  if (seen_ != size_) {
    throw std::logic_error("ByteHasher: " + std::to_string(seen_) + " bytes hashed, " + std::to_string(size_) +
                           " announced");
  }
  std::uint64_t a = a_;
  for (std::size_t i = 0; i < partSize_; ++i) a = (a ^ part_[i]) * 0x100000001b3ULL;
  return mix(a ^ mix(b_));
}

std::uint64_t hashBytes(const void* data, std::size_t size, std::uint64_t h) {
  ByteHasher hasher(h, size);
  hasher.update(data, size);
  return hasher.finish();
}

namespace {

// StateOut's encoding of a checkpoint's body, streamed to a file through a
// bounded buffer and hashed on the way. The hash starts from the body's length,
// so the body is first put through one that only counts (fd < 0).
class BodyOut : public StateEncoder<BodyOut> {
 public:
  BodyOut(int fd, std::size_t size, const std::string& path) : fd_(fd), path_(path), sum_(0, size) {
    if (fd_ >= 0) buf_.reserve(kBuffer);
  }
  std::size_t size() const { return size_; }
  // the rest of the body, then its checksum
  void finish() {
    flush();
    const std::uint64_t sum = sum_.finish();
    writeAll(fd_, reinterpret_cast<const char*>(&sum), sizeof sum, path_);
  }
  // StateEncoder's sink
  void raw(const void* data, std::size_t n) {
    size_ += n;
    if (fd_ < 0) return;
    const auto* p = static_cast<const char*>(data);
    while (n > 0) {
      const std::size_t take = std::min(n, kBuffer - buf_.size());
      buf_.insert(buf_.end(), p, p + take);
      p += take;
      n -= take;
      if (buf_.size() == kBuffer) flush();
    }
  }

 private:
  static constexpr std::size_t kBuffer = std::size_t{4} << 20;

  void flush() {
    sum_.update(buf_.data(), buf_.size());
    writeAll(fd_, buf_.data(), buf_.size(), path_);
    buf_.clear();
  }

  int fd_;
  std::string path_;
  ByteHasher sum_;
  std::size_t size_ = 0;
  std::vector<char> buf_;
};

void putBody(BodyOut& out, const CheckpointView& c) {
  for (char ch : kMagic) out.put(ch);
  out.put(kVersion);
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
}

}  // namespace

void writeCheckpoint(const std::string& path, const CheckpointView& c) {
  BodyOut counted(-1, 0, path);
  putBody(counted, c);

  const std::string tmp = path + ".new";
  ::unlink(tmp.c_str());
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd < 0) throw OutputError(tmp + ": cannot create checkpoint: " + std::strerror(errno));
  try {
    BodyOut out(fd, counted.size(), tmp);
    putBody(out, c);
    out.finish();
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
