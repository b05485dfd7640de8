#pragma once
// Reading checked values out of scenario JSON.
//
// A JsonReader wraps one JSON object together with the file it came from and
// its JSON path (e.g. `swarms[1].params`). Every value read is checked (type,
// range, finite) and recorded, with its default filled in, into a "resolved"
// JSON object, so the resolved scenario can be printed and stored. `finish()`
// reports any key that was never read, which catches typos.
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "core/input_files.hpp"
#include "core/vec.hpp"

namespace swarmsim {

using Json = nlohmann::json;

// Magnitude limits of scenario values (docs/scenario.md#limits). The agents'
// state is float (largest value ~3.4e38, 24-bit mantissa). With every
// position within kMaxCoordinate, every speed within kMaxSpeed and dt within
// [kMinDt, kMaxDt], one step moves an agent at most kMaxSpeed * kMaxDt = 1e9 m,
// squared distances stay below ~1e19 and 1/dt, 1/dt^2 below 1e12, so the
// float computations of every model stay finite; below kMinLength,
// kMinSpeed and kMinDuration a positive value would round to 0 or divide to
// Inf in float, or vanish below the resolution of positions.
constexpr double kMaxCoordinate = 1e9;  // m: any position (domain, spawn, obstacles, goals, stimuli, ...)
constexpr double kMaxLength = 1e9;      // m: radii, zones, distances, margins
constexpr double kMinLength = 1e-6;     // m: smallest positive length (1 µm)
constexpr double kMaxSpeed = 1e6;       // m/s: speeds and velocity weights
constexpr double kMinSpeed = 1e-6;      // m/s: smallest positive speed where one must be > 0
constexpr double kMinDt = 1e-6;         // s
constexpr double kMaxDt = 1e3;          // s
constexpr double kMinDuration = 1e-6;   // s: time horizons, response times
constexpr double kMaxDuration = 1e9;    // s

// Allowed range of a number, with its wording for error messages: the range
// of the key's meaning (e.g. > 0) and, on top, the magnitude limits above
// (closed; 0 may be exempt). A number outside the first is reported with its
// wording ("a number > 0"), one outside the limits with the combined range
// ("a number in [1e-06, 1000]").
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool loOpen = false;
  bool hiOpen = false;
  double limitLo = -std::numeric_limits<double>::infinity();
  double limitHi = std::numeric_limits<double>::infinity();
  bool zeroExempt = false;  // 0 is allowed whatever the limits ("0 or a number in [a, b]")

  static Range any() { return {}; }
  static Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Range nonNegative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Range atLeast(double v) { return {v, std::numeric_limits<double>::infinity(), false, false}; }
  static Range closed(double a, double b) { return {a, b, false, false}; }
  // this range, limited to [a, b] (0 exempt if zeroToo)
  Range limited(double a, double b, bool zeroToo = false) const {
    Range r = *this;
    r.limitLo = a;
    r.limitHi = b;
    r.zeroExempt = zeroToo;
    return r;
  }
  // the limits above
  static Range coordinate() { return any().limited(-kMaxCoordinate, kMaxCoordinate); }
  static Range length() { return positive().limited(kMinLength, kMaxLength); }  // a positive length
  static Range lengthOrZero() { return nonNegative().limited(kMinLength, kMaxLength, true); }
  static Range speed() { return nonNegative().limited(0.0, kMaxSpeed); }
  static Range positiveSpeed() { return positive().limited(kMinSpeed, kMaxSpeed); }
  static Range duration() { return positive().limited(kMinDuration, kMaxDuration); }

  bool contains(double v) const;
  // e.g. "a number > 0", "a number in [0, 360]", "a finite number", "0 or a number in [1e-06, 1e+09]"
  std::string describe(const char* noun = "a number") const;
  // the wording for an error about value v: without the limits unless v is a number that meets
  // the key's own range (so that "-1" gets "a number >= 0")
  std::string describeFor(const Json& v, const char* noun = "a number") const;
};

// Limits of scenario JSON (docs/scenario.md#limits): at most this many levels
// of nested arrays and objects, and files of at most this many bytes.
constexpr std::size_t kMaxJsonDepth = 256;
constexpr std::size_t kMaxJsonFileBytes = std::size_t{64} << 20;  // 64 MiB

// Parse JSON text into a DOM (nlohmann's SAX interface, so no recursion that
// depends on the input). An InputError names `file` and: line and column for
// malformed text or a number too large for a double; the JSON path for a
// duplicate key or nesting deeper than kMaxJsonDepth.
Json parseJsonText(const std::string& text, const std::string& file);
// As parseJsonText for a value that goes at JSON path `path`, under `depth`
// levels of arrays and objects (a --set value): malformed text gives nullopt;
// duplicate keys and nesting beyond kMaxJsonDepth in all give an InputError
// starting with `where`.
std::optional<Json> parseJsonValue(const std::string& text, const std::string& where, const std::string& path,
                                   std::size_t depth);
// read (at most kMaxJsonFileBytes; a directory is refused) and parse a JSON file; kStdinName or "-"
// reads standard input
Json readJsonFile(const std::string& path);
// the name a scenario read from standard input goes by in messages
inline const char* const kStdinName = "<stdin>";
// `relative` resolved against the folder of `scenarioFile` (the working folder for kStdinName), made
// absolute and lexically normal; an absolute path is only normalised
std::string resolveInputPath(const std::string& scenarioFile, const std::string& relative);
// compact, length-limited rendering of a value for error messages
std::string describeValue(const Json& v);

class JsonReader {
 public:
  // `resolved` receives every value read, defaults filled in; it may be null
  // `resolved` receives every value read, defaults filled in; it may be null. `inputs` (passed on to the
  // readers of nested objects) receives the mesh files read through inputFile(); it may be null.
  JsonReader(const Json& object, std::string file, std::string path, Json* resolved,
             std::shared_ptr<InputFiles> inputs = nullptr);

  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  // JSON path of a key of this object, e.g. "swarms[1].params.repulsion_zone"
  std::string pathOf(const std::string& key) const;
  bool has(const std::string& key) const;

  double number(const std::string& key, double fallback, Range range = Range::any());
  double requireNumber(const std::string& key, Range range = Range::any());
  std::int64_t integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi);
  std::int64_t requireInteger(const std::string& key, std::int64_t lo, std::int64_t hi);
  // any integer in [0, 2^64 - 1], kept exactly (seeds)
  std::uint64_t unsignedInteger(const std::string& key, std::uint64_t fallback);
  bool boolean(const std::string& key, bool fallback);
  std::string string(const std::string& key, const std::string& fallback);
  std::string requireString(const std::string& key);
  // a required file path: a relative one resolves against the folder of the scenario file (the working
  // folder when the scenario came from standard input, kStdinName); the resolved scenario records the
  // absolute path, so that it means the same file wherever it is run from
  std::string requireInputPath(const std::string& key);
  const std::shared_ptr<InputFiles>& inputs() const { return inputs_; }
  // one of a fixed set of strings
  std::string choice(const std::string& key, const std::string& fallback, const std::vector<std::string>& options);
  Vec3d vec3(const std::string& key, const Vec3d& fallback, Range range = Range::any());
  Vec3d requireVec3(const std::string& key, Range range = Range::any());
  std::vector<std::string> stringList(const std::string& key, const std::vector<std::string>& fallback,
                                      const std::vector<std::string>& options);

  // nested object (required, or empty object when absent and optional)
  JsonReader object(const std::string& key, bool required);
  // array of objects
  std::vector<JsonReader> objectArray(const std::string& key, bool required, std::size_t minSize);

  // raw access: marks the key read, records the value verbatim
  const Json* raw(const std::string& key);
  // record a value computed from others (a derived default) as the key's resolved value
  void resolve(const std::string& key, Json value);

  // error for unknown keys (keys that were never read)
  void finish() const;

  [[noreturn]] void fail(const std::string& key, const std::string& message) const;
  [[noreturn]] void failExpected(const std::string& key, const std::string& expected, const Json& got) const;

 private:
  const Json* lookup(const std::string& key);
  double checkedNumber(const std::string& key, const Json& v, Range range) const;
  Vec3d checkedVec3(const std::string& key, const Json& v, Range range) const;
  void record(const std::string& key, Json value);
  // a key of this object close to `key` (a likely typo) that was never read, or ""
  std::string closeUnreadKey(const std::string& key) const;

 public:
  // error for a missing required key; names a likely typo of it instead if there is one
  [[noreturn]] void failMissing(const std::string& key, const std::string& expected) const;

  const Json* object_;
  std::string file_;
  std::string path_;
  Json* resolved_;
  std::shared_ptr<InputFiles> inputs_;
  std::set<std::string> read_;
};

}  // namespace swarmsim
