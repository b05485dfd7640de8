#pragma once
// A byte buffer for checkpoint state: what a model carries from one step to the
// next besides its SwarmState (Model::saveState / loadState). Values are
// written in native byte order (a checkpoint is resumed on the machine kind
// that wrote it); a reader that runs past the end throws, so a checkpoint of
// another version or a damaged one is refused rather than misread.
#include <cstdint>
#include <cstring>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace swarmsim {

// The encoding of checkpoint values (native byte order, sizes as 64-bit counts) onto any sink: Sink has
// raw(data, n), which takes n bytes. StateOut keeps them in memory; the checkpoint file streams them (io/checkpoint.cpp).
template <typename Sink>
class StateEncoder {
 public:
  template <typename T>
  void put(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>, "plain values only");
    sink().raw(&v, sizeof(T));
  }
  template <typename T>
  void putVector(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>, "plain values only");
    put<std::uint64_t>(v.size());
    sink().raw(v.data(), v.size() * sizeof(T));
  }
  void putString(const std::string& s) {
    put<std::uint64_t>(s.size());
    sink().raw(s.data(), s.size());
  }

 private:
  Sink& sink() { return static_cast<Sink&>(*this); }
};

class StateOut : public StateEncoder<StateOut> {
 public:
  const std::string& bytes() const { return bytes_; }
  void raw(const void* data, std::size_t n) { bytes_.append(static_cast<const char*>(data), n); }

 private:
  std::string bytes_;
};

class StateIn {
 public:
  explicit StateIn(const std::string& bytes) : bytes_(bytes) {}
  template <typename T>
  T get() {
    static_assert(std::is_trivially_copyable_v<T>, "plain values only");
    T v;
    take(&v, sizeof(T));
    return v;
  }
  template <typename T>
  std::vector<T> getVector() {
    const auto n = get<std::uint64_t>();
    if (n > (bytes_.size() - pos_) / sizeof(T)) throw std::runtime_error("checkpoint state: vector longer than the data");
    std::vector<T> v(static_cast<std::size_t>(n));
    take(v.data(), v.size() * sizeof(T));
    return v;
  }
  std::string getString() {
    const auto n = get<std::uint64_t>();
    if (n > bytes_.size() - pos_) throw std::runtime_error("checkpoint state: string longer than the data");
    std::string s = bytes_.substr(pos_, static_cast<std::size_t>(n));
    pos_ += s.size();
    return s;
  }
  bool atEnd() const { return pos_ == bytes_.size(); }

 private:
  void take(void* dst, std::size_t n) {
    if (n > bytes_.size() - pos_) throw std::runtime_error("checkpoint state: shorter than expected");
    if (n > 0) std::memcpy(dst, bytes_.data() + pos_, n);
    pos_ += n;
  }
  const std::string& bytes_;
  std::size_t pos_ = 0;
};

}  // namespace swarmsim
