#pragma once
// Reading checked values out of scenario JSON.
//
// A JsonReader wraps one JSON object together with the file it came from and
// its JSON path (e.g. `swarms[1].params`). Every value read is checked (type,
// range, finite) and recorded, with its default filled in, into a "resolved"
// JSON object, so the resolved scenario can be printed and stored. `finish()`
// reports any key that was never read, which catches typos.
#include <cstdint>
#include <limits>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "core/vec.hpp"

namespace swarmsim {

using Json = nlohmann::json;

// allowed range of a number, with its wording for error messages
struct Range {
  double lo = -std::numeric_limits<double>::infinity();
  double hi = std::numeric_limits<double>::infinity();
  bool loOpen = false;
  bool hiOpen = false;

  static Range any() { return {}; }
  static Range positive() { return {0.0, std::numeric_limits<double>::infinity(), true, false}; }
  static Range nonNegative() { return {0.0, std::numeric_limits<double>::infinity(), false, false}; }
  static Range atLeast(double v) { return {v, std::numeric_limits<double>::infinity(), false, false}; }
  static Range closed(double a, double b) { return {a, b, false, false}; }

  bool contains(double v) const;
  // e.g. "a number > 0", "a number in [0, 360]", "a finite number"
  std::string describe(const char* noun = "a number") const;
};

// parse JSON text; malformed text gives an InputError naming file, line and column
Json parseJsonText(const std::string& text, const std::string& file);
// read and parse a JSON file
Json readJsonFile(const std::string& path);
// compact, length-limited rendering of a value for error messages
std::string describeValue(const Json& v);

class JsonReader {
 public:
  // `resolved` receives every value read, defaults filled in; it may be null
  JsonReader(const Json& object, std::string file, std::string path, Json* resolved);

  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  // JSON path of a key of this object, e.g. "swarms[1].params.repulsion_zone"
  std::string pathOf(const std::string& key) const;
  bool has(const std::string& key) const;

  double number(const std::string& key, double fallback, Range range = Range::any());
  double requireNumber(const std::string& key, Range range = Range::any());
  std::int64_t integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi);
  std::int64_t requireInteger(const std::string& key, std::int64_t lo, std::int64_t hi);
  bool boolean(const std::string& key, bool fallback);
  std::string string(const std::string& key, const std::string& fallback);
  std::string requireString(const std::string& key);
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
  std::set<std::string> read_;
};

}  // namespace swarmsim
