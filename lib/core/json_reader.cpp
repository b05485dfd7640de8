#include "core/json_reader.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>

#include "core/error.hpp"

namespace swarmsim {

namespace {

std::string formatNumber(double v) {
  std::ostringstream s;
  s << v;
  return s.str();
}

// edit distance, for "did you mean" suggestions
std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

}  // namespace

bool Range::contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (loOpen ? !(v > lo) : !(v >= lo)) return false;
  if (hiOpen ? !(v < hi) : !(v <= hi)) return false;
  return true;
}

std::string Range::describe(const char* noun) const {
  const bool hasLo = std::isfinite(lo), hasHi = std::isfinite(hi);
  std::string n = noun;
  if (hasLo && hasHi) {
    return n + " in " + (loOpen ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) + (hiOpen ? ")" : "]");
  }
  if (hasLo) return n + (loOpen ? " > " : " >= ") + formatNumber(lo);
  if (hasHi) return n + (hiOpen ? " < " : " <= ") + formatNumber(hi);
  return "a finite " + n.substr(n.find(' ') + 1);
}

Json parseJsonText(const std::string& text, const std::string& file) {
  try {
    return Json::parse(text);
  } catch (const Json::parse_error& e) {
    // turn the byte offset into line and column
    const std::size_t end = std::min<std::size_t>(e.byte > 0 ? e.byte - 1 : 0, text.size());
    std::size_t line = 1, col = 1;
    for (std::size_t i = 0; i < end; ++i) {
      if (text[i] == '\n') {
        ++line;
        col = 1;
      } else {
        ++col;
      }
    }
    std::string reason = e.what();
    const auto colon = reason.find(": ", reason.find("parse error"));
    if (colon != std::string::npos) reason = reason.substr(colon + 2);
    throw InputError(file + ":" + std::to_string(line) + ":" + std::to_string(col) + ": malformed JSON: " + reason);
  } catch (const Json::out_of_range& e) {
    // a number too large for a double (e.g. 1e999 would be Inf); locate the literal
    std::string what = e.what(), literal;
    const auto q1 = what.find('\''), q2 = what.rfind('\'');
    if (q1 != std::string::npos && q2 > q1) literal = what.substr(q1 + 1, q2 - q1 - 1);
    std::string where = file;
    const auto pos = literal.empty() ? std::string::npos : text.find(literal);
    if (pos != std::string::npos) {
      const std::size_t line = 1 + static_cast<std::size_t>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
      const auto nl = text.rfind('\n', pos);
      const std::size_t col = pos - (nl == std::string::npos ? 0 : nl + 1) + 1;
      where += ":" + std::to_string(line) + ":" + std::to_string(col);
    }
    throw InputError(where + ": expected a finite number, got " + (literal.empty() ? "an out-of-range number" : literal) +
                     " (out of range: it would be Inf)");
  }
}

Json readJsonFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file (expected a readable JSON scenario)");
  std::ostringstream buf;
  buf << in.rdbuf();
  return parseJsonText(buf.str(), path);
}

std::string describeValue(const Json& v) {
  if (v.is_number_float() && !std::isfinite(v.get<double>())) {
    const double d = v.get<double>();
    return std::isnan(d) ? "NaN" : (d > 0 ? "inf" : "-inf");
  }
  std::string s = v.dump();
  if (s.size() > 60) s = s.substr(0, 57) + "...";
  const char* type = v.is_object() ? "object " : v.is_array() ? "array " : v.is_null() ? "" : "";
  return type + s;
}

JsonReader::JsonReader(const Json& object, std::string file, std::string path, Json* resolved)
    : object_(&object), file_(std::move(file)), path_(std::move(path)), resolved_(resolved) {
  if (resolved_ && !resolved_->is_object()) *resolved_ = Json::object();
}

std::string JsonReader::pathOf(const std::string& key) const { return path_.empty() ? key : path_ + "." + key; }

bool JsonReader::has(const std::string& key) const {
  const auto it = object_->find(key);
  return it != object_->end() && !it->is_null();  // null counts as absent
}

std::string JsonReader::closeUnreadKey(const std::string& key) const {
  std::string best;
  std::size_t bestDist = 3;
  for (const auto& item : object_->items()) {
    if (read_.count(item.key()) || item.key() == key) continue;
    const std::size_t d = editDistance(item.key(), key);
    if (d < bestDist) {
      bestDist = d;
      best = item.key();
    }
  }
  return best;
}

void JsonReader::failMissing(const std::string& key, const std::string& expected) const {
  const std::string typo = closeUnreadKey(key);
  if (!typo.empty()) {
    fail(typo, "unknown key (did you mean \"" + key + "\"?); \"" + key + "\" is required (expected " + expected + ")");
  }
  fail(key, "missing required key (expected " + expected + ")");
}

void JsonReader::fail(const std::string& key, const std::string& message) const {
  const std::string where = key.empty() ? (path_.empty() ? std::string("(top level)") : path_) : pathOf(key);
  throw InputError(file_ + ": " + where + ": " + message);
}

void JsonReader::failExpected(const std::string& key, const std::string& expected, const Json& got) const {
  fail(key, "expected " + expected + ", got " + describeValue(got));
}

const Json* JsonReader::lookup(const std::string& key) {
  read_.insert(key);
  auto it = object_->find(key);
  if (it == object_->end() || it->is_null()) return nullptr;
  return &*it;
}

const Json* JsonReader::raw(const std::string& key) {
  const Json* v = lookup(key);
  if (v) record(key, *v);
  return v;
}

void JsonReader::resolve(const std::string& key, Json value) {
  read_.insert(key);
  record(key, std::move(value));
}

void JsonReader::record(const std::string& key, Json value) {
  if (resolved_) (*resolved_)[key] = std::move(value);
}

double JsonReader::checkedNumber(const std::string& key, const Json& v, Range range) const {
  if (!v.is_number()) failExpected(key, range.describe(), v);
  const double d = v.get<double>();
  if (!range.contains(d)) failExpected(key, range.describe(), v);
  return d;
}

double JsonReader::number(const std::string& key, double fallback, Range range) {
  const Json* v = lookup(key);
  const double d = v ? checkedNumber(key, *v, range) : fallback;
  record(key, d);
  return d;
}

double JsonReader::requireNumber(const std::string& key, Range range) {
  const Json* v = lookup(key);
  if (!v) failMissing(key, range.describe());
  const double d = checkedNumber(key, *v, range);
  record(key, d);
  return d;
}

std::int64_t JsonReader::integer(const std::string& key, std::int64_t fallback, std::int64_t lo, std::int64_t hi) {
  if (!has(key) || object_->at(key).is_null()) {
    read_.insert(key);
    record(key, fallback);
    return fallback;
  }
  return requireInteger(key, lo, hi);
}

std::int64_t JsonReader::requireInteger(const std::string& key, std::int64_t lo, std::int64_t hi) {
  const Json* v = lookup(key);
  std::string expected = "an integer";
  if (hi == std::numeric_limits<std::int64_t>::max()) {
    expected += " >= " + std::to_string(lo);
  } else {
    expected += " in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  }
  if (!v) failMissing(key, expected);
  std::int64_t value = 0;
  if (v->is_number_integer()) {
    if (v->is_number_unsigned() && v->get<std::uint64_t>() > static_cast<std::uint64_t>(hi)) {
      failExpected(key, expected, *v);
    }
    value = v->get<std::int64_t>();
  } else if (v->is_number_float() && std::isfinite(v->get<double>()) && std::floor(v->get<double>()) == v->get<double>() &&
             std::fabs(v->get<double>()) < 9e15) {
    value = static_cast<std::int64_t>(v->get<double>());  // 1e5 is an integer too
  } else {
    failExpected(key, expected, *v);
  }
  if (value < lo || value > hi) failExpected(key, expected, *v);
  record(key, value);
  return value;
}

bool JsonReader::boolean(const std::string& key, bool fallback) {
  const Json* v = lookup(key);
  if (v && !v->is_boolean()) failExpected(key, "true or false", *v);
  const bool b = v ? v->get<bool>() : fallback;
  record(key, b);
  return b;
}

std::string JsonReader::string(const std::string& key, const std::string& fallback) {
  const Json* v = lookup(key);
  if (v && !v->is_string()) failExpected(key, "a string", *v);
  std::string s = v ? v->get<std::string>() : fallback;
  record(key, s);
  return s;
}

std::string JsonReader::requireString(const std::string& key) {
  const Json* v = lookup(key);
  if (!v) failMissing(key, "a string");
  if (!v->is_string() || v->get<std::string>().empty()) failExpected(key, "a non-empty string", *v);
  record(key, *v);
  return v->get<std::string>();
}

std::string JsonReader::choice(const std::string& key, const std::string& fallback,
                               const std::vector<std::string>& options) {
  const Json* v = lookup(key);
  std::string expected = "one of";
  for (std::size_t i = 0; i < options.size(); ++i) expected += (i ? ", \"" : " \"") + options[i] + "\"";
  if (v && (!v->is_string() || std::find(options.begin(), options.end(), v->get<std::string>()) == options.end())) {
    failExpected(key, expected, *v);
  }
  std::string s = v ? v->get<std::string>() : fallback;
  record(key, s);
  return s;
}

Vec3d JsonReader::checkedVec3(const std::string& key, const Json& v, Range range) const {
  const std::string expected = "an array of 3 numbers";
  if (!v.is_array() || v.size() != 3) failExpected(key, expected, v);
  Vec3d out;
  for (int i = 0; i < 3; ++i) {
    const Json& c = v[static_cast<std::size_t>(i)];
    if (!c.is_number() || !range.contains(c.get<double>())) {
      fail(key + "[" + std::to_string(i) + "]", "expected " + range.describe() + ", got " + describeValue(c));
    }
    out[i] = c.get<double>();
  }
  return out;
}

Vec3d JsonReader::vec3(const std::string& key, const Vec3d& fallback, Range range) {
  const Json* v = lookup(key);
  const Vec3d out = v ? checkedVec3(key, *v, range) : fallback;
  record(key, Json::array({out.x(), out.y(), out.z()}));
  return out;
}

Vec3d JsonReader::requireVec3(const std::string& key, Range range) {
  const Json* v = lookup(key);
  if (!v) failMissing(key, "an array of 3 numbers");
  const Vec3d out = checkedVec3(key, *v, range);
  record(key, Json::array({out.x(), out.y(), out.z()}));
  return out;
}

std::vector<std::string> JsonReader::stringList(const std::string& key, const std::vector<std::string>& fallback,
                                                const std::vector<std::string>& options) {
  const Json* v = lookup(key);
  std::string expected = "an array of strings from";
  for (std::size_t i = 0; i < options.size(); ++i) expected += (i ? ", \"" : " \"") + options[i] + "\"";
  std::vector<std::string> out = fallback;
  if (v) {
    if (!v->is_array()) failExpected(key, expected, *v);
    out.clear();
    for (std::size_t i = 0; i < v->size(); ++i) {
      const Json& e = (*v)[i];
      if (!e.is_string() || std::find(options.begin(), options.end(), e.get<std::string>()) == options.end()) {
        fail(key + "[" + std::to_string(i) + "]", "expected " + expected.substr(expected.find("from ") + 5) +
                                                      ", got " + describeValue(e));
      }
      if (std::find(out.begin(), out.end(), e.get<std::string>()) == out.end()) out.push_back(e.get<std::string>());
    }
  }
  record(key, out);
  return out;
}

JsonReader JsonReader::object(const std::string& key, bool required) {
  static const Json kEmpty = Json::object();
  const Json* v = lookup(key);
  if (!v && required) failMissing(key, "an object");
  if (v && !v->is_object()) failExpected(key, "an object", *v);
  Json* sub = nullptr;
  if (resolved_) {
    (*resolved_)[key] = Json::object();
    sub = &(*resolved_)[key];
  }
  return JsonReader(v ? *v : kEmpty, file_, pathOf(key), sub);
}

std::vector<JsonReader> JsonReader::objectArray(const std::string& key, bool required, std::size_t minSize) {
  static const Json kEmpty = Json::array();
  const Json* v = lookup(key);
  const std::string expected = "an array of at least " + std::to_string(minSize) + " object" + (minSize == 1 ? "" : "s");
  if (!v && required) failMissing(key, expected);
  if (!v) v = &kEmpty;
  if (!v->is_array() || v->size() < minSize) failExpected(key, expected, *v);
  Json* sub = nullptr;
  if (resolved_) {
    (*resolved_)[key] = Json::array();
    for (std::size_t i = 0; i < v->size(); ++i) (*resolved_)[key].push_back(Json::object());
    sub = &(*resolved_)[key];
  }
  std::vector<JsonReader> out;
  for (std::size_t i = 0; i < v->size(); ++i) {
    const std::string p = pathOf(key) + "[" + std::to_string(i) + "]";
    if (!(*v)[i].is_object()) throw InputError(file_ + ": " + p + ": expected an object, got " + describeValue((*v)[i]));
    out.emplace_back((*v)[i], file_, p, sub ? &(*sub)[i] : nullptr);
  }
  return out;
}

void JsonReader::finish() const {
  for (const auto& item : object_->items()) {
    if (read_.count(item.key())) continue;
    std::string best;
    std::size_t bestDist = 3;  // suggest only close matches
    for (const auto& known : read_) {
      const std::size_t d = editDistance(item.key(), known);
      if (d < bestDist) {
        bestDist = d;
        best = known;
      }
    }
    std::string known;
    for (const auto& k : read_) known += (known.empty() ? "" : ", ") + k;
    fail(item.key(), "unknown key" + (best.empty() ? std::string() : " (did you mean \"" + best + "\"?)") +
                         "; expected one of: " + known);
  }
}

}  // namespace swarmsim
