#include "core/json_reader.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "core/error.hpp"

namespace swarmsim {

namespace fs = std::filesystem;

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

namespace {

// the wording of [lo, hi] with open or closed ends
std::string describeInterval(const std::string& n, double lo, double hi, bool loOpen, bool hiOpen) {
  const bool hasLo = std::isfinite(lo), hasHi = std::isfinite(hi);
  if (hasLo && hasHi) {
    return n + " in " + (loOpen ? "(" : "[") + formatNumber(lo) + ", " + formatNumber(hi) + (hiOpen ? ")" : "]");
  }
  if (hasLo) return n + (loOpen ? " > " : " >= ") + formatNumber(lo);
  if (hasHi) return n + (hiOpen ? " < " : " <= ") + formatNumber(hi);
  return "a finite " + n.substr(n.find(' ') + 1);
}

}  // namespace

bool Range::contains(double v) const {
  if (!std::isfinite(v)) return false;
  if (loOpen ? !(v > lo) : !(v >= lo)) return false;
  if (hiOpen ? !(v < hi) : !(v <= hi)) return false;
  if (zeroExempt && v == 0.0) return true;
  return v >= limitLo && v <= limitHi;
}

std::string Range::describe(const char* noun) const {
  // the intersection of the key's range and the limits
  double a = lo, b = hi;
  bool aOpen = loOpen, bOpen = hiOpen;
  if (limitLo > a || (limitLo == a && !aOpen)) {
    a = limitLo;
    aOpen = false;
  }
  if (limitHi < b || (limitHi == b && !bOpen)) {
    b = limitHi;
    bOpen = false;
  }
  const std::string text = describeInterval(noun, a, b, aOpen, bOpen);
  return zeroExempt && !(a <= 0.0 && 0.0 <= b) ? "0 or " + text : text;
}

std::string Range::describeFor(const Json& v, const char* noun) const {
  const Range own{lo, hi, loOpen, hiOpen};
  if (v.is_number() && own.contains(v.get<double>())) return describe(noun);
  return describeInterval(noun, lo, hi, loOpen, hiOpen);
}

namespace {

// A JSON path for messages, shortened in the middle when very long (a path
// at the depth limit is hundreds of "[0]")
std::string shortPath(const std::string& path) {
  if (path.size() <= 120) return path;
  // cut before a '[' or '.', so that whole keys and indices remain
  std::size_t head = path.find_last_of("[.", 70), tail = path.find_first_of("[.", path.size() - 40);
  if (head == std::string::npos || head == 0) head = 70;
  if (tail == std::string::npos) tail = path.size() - 40;
  return path.substr(0, head) + "..." + path.substr(tail);
}

// line and column (1-based) of byte offset `pos` of text
std::string lineColumn(const std::string& text, std::size_t pos) {
  pos = std::min(pos, text.size());
  std::size_t line = 1, col = 1;
  for (std::size_t i = 0; i < pos; ++i) {
    if (text[i] == '\n') {
      ++line;
      col = 1;
    } else {
      ++col;
    }
  }
  return std::to_string(line) + ":" + std::to_string(col);
}

// Builds the DOM from nlohmann's SAX events (so no recursion depends on the
// input), refusing nesting deeper than maxDepth and duplicate keys.
class DomBuilder final : public nlohmann::json_sax<Json> {
 public:
  enum class Failure { kNone, kSyntax, kNumber, kDepth, kDuplicate };

  // basePath/baseDepth: where the text goes in a larger document (--set)
  DomBuilder(Json& root, std::size_t maxDepth, std::string basePath, std::size_t baseDepth)
      : root_(root), maxDepth_(maxDepth), basePath_(std::move(basePath)), baseDepth_(baseDepth) {}

  bool null() override { return put(Json(nullptr)); }
  bool boolean(bool v) override { return put(Json(v)); }
  bool number_integer(number_integer_t v) override { return put(Json(v)); }
  bool number_unsigned(number_unsigned_t v) override { return put(Json(v)); }
  bool number_float(number_float_t v, const string_t&) override { return put(Json(v)); }
  bool string(string_t& v) override { return put(Json(std::move(v))); }
  bool binary(binary_t& v) override { return put(Json::binary(std::move(v))); }  // not produced by JSON text
  bool start_object(std::size_t) override { return open(Json::object()); }
  bool start_array(std::size_t) override { return open(Json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& k) override {
    Frame& f = stack_.back();
    if (f.node->contains(k)) {
      failure_ = Failure::kDuplicate;
      const std::string where = pathTo(stack_.size() - 1);
      message_ = "duplicate key \"" + k + "\" " +
                 (where.empty() ? std::string("at the top level") : "in " + shortPath(where)) +
                 " (expected each key at most once per object)";
      return false;
    }
    f.key = k;
    return true;
  }
  bool parse_error(std::size_t position, const std::string& token, const nlohmann::detail::exception& ex) override {
    position_ = position;
    token_ = token;
    if (ex.id == 406) {  // out_of_range: a number too large for a double
      failure_ = Failure::kNumber;
    } else {
      failure_ = Failure::kSyntax;
      message_ = ex.what();
      const auto colon = message_.find(": ", message_.find("parse error"));
      if (colon != std::string::npos) message_ = message_.substr(colon + 2);
    }
    return false;
  }

  Failure failure() const { return failure_; }
  const std::string& message() const { return message_; }
  std::size_t position() const { return position_; }
  const std::string& token() const { return token_; }

 private:
  struct Frame {
    Json* node;
    std::string key;  // objects: the key of the value being read
  };

  // JSON path of the value being read in frame `upTo - 1` (frames [0, upTo) are its ancestors)
  std::string pathTo(std::size_t upTo) const {
    std::string p = basePath_;
    for (std::size_t i = 0; i < upTo; ++i) {
      const Frame& f = stack_[i];
      if (f.node->is_array()) {
        p += "[" + std::to_string(f.node->size() - 1) + "]";
      } else {
        p += (p.empty() ? "" : ".") + f.key;
      }
    }
    return p;
  }
  // where the next value goes
  Json* slot() {
    if (stack_.empty()) return &root_;
    Frame& f = stack_.back();
    if (f.node->is_array()) {
      f.node->push_back(nullptr);
      return &f.node->back();
    }
    return &(*f.node)[f.key];
  }
  bool put(Json v) {
    *slot() = std::move(v);
    return true;
  }
  bool open(Json v) {
    Json* s = slot();
    if (baseDepth_ + stack_.size() >= maxDepth_) {
      failure_ = Failure::kDepth;
      message_ = shortPath(pathTo(stack_.size())) + ": nested deeper than " + std::to_string(maxDepth_) +
                 " levels (expected at most " + std::to_string(maxDepth_) + " levels of arrays and objects)";
      return false;
    }
    *s = std::move(v);
    stack_.push_back({s, {}});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  Json& root_;
  std::size_t maxDepth_;
  std::string basePath_;
  std::size_t baseDepth_;
  std::vector<Frame> stack_;
  Failure failure_ = Failure::kNone;
  std::string message_, token_;
  std::size_t position_ = 0;
};

}  // namespace

Json parseJsonText(const std::string& text, const std::string& file) {
  Json root;
  DomBuilder dom(root, kMaxJsonDepth, "", 0);
  if (Json::sax_parse(text, &dom)) return root;
  switch (dom.failure()) {
    case DomBuilder::Failure::kSyntax: {
      // the parser's byte count is one past the offending character
      const std::size_t at = dom.position() > 0 ? dom.position() - 1 : 0;
      throw InputError(file + ":" + lineColumn(text, at) + ": malformed JSON: " + dom.message());
    }
    case DomBuilder::Failure::kNumber: {
      // a number too large for a double (e.g. 1e999 would be Inf): the literal ends before the position
      const std::string& literal = dom.token();
      std::string where = file;
      const std::size_t end = std::min(dom.position(), text.size());
      const auto pos = literal.empty() ? std::string::npos : text.rfind(literal, end);
      if (pos != std::string::npos) where += ":" + lineColumn(text, pos);
      throw InputError(where + ": expected a finite number, got " +
                       (literal.empty() ? std::string("an out-of-range number") : literal) +
                       " (out of range: it would be Inf)");
    }
    default:
      throw InputError(file + ": " + dom.message());
  }
}

std::optional<Json> parseJsonValue(const std::string& text, const std::string& where, const std::string& path,
                                   std::size_t depth) {
  Json root;
  DomBuilder dom(root, kMaxJsonDepth, path, depth);
  if (Json::sax_parse(text, &dom)) return root;
  if (dom.failure() == DomBuilder::Failure::kSyntax || dom.failure() == DomBuilder::Failure::kNumber) {
    return std::nullopt;
  }
  throw InputError(where + ": " + dom.message());
}

namespace {

// read a stream in blocks up to the limit, so a device or pipe without end (/dev/zero) is refused
std::string readLimited(std::istream& in, const std::string& name) {
  std::string text;
  std::vector<char> block(1 << 16);
  while (in) {
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    text.append(block.data(), static_cast<std::size_t>(in.gcount()));
    if (text.size() > kMaxJsonFileBytes) {
      throw InputError(name + ": file is larger than " + std::to_string(kMaxJsonFileBytes >> 20) +
                       " MiB (expected a JSON scenario of at most " + std::to_string(kMaxJsonFileBytes >> 20) +
                       " MiB)");
    }
  }
  if (in.bad()) throw InputError(name + ": cannot read file (read error; expected a readable JSON scenario)");
  return text;
}

}  // namespace

Json readJsonFile(const std::string& path) {
  if (path == "-" || path == kStdinName) return parseJsonText(readLimited(std::cin, kStdinName), kStdinName);
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InputError(path + ": cannot read file (it is a directory; expected a JSON scenario file)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file (expected a readable JSON scenario)");
  return parseJsonText(readLimited(in, path), path);
}

std::string resolveInputPath(const std::string& scenarioFile, const std::string& relative) {
  fs::path p(relative);
  if (p.is_relative() && scenarioFile != kStdinName) p = fs::path(scenarioFile).parent_path() / p;
  return fs::absolute(p).lexically_normal().string();
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

JsonReader::JsonReader(const Json& object, std::string file, std::string path, Json* resolved,
                       std::shared_ptr<InputFiles> inputs)
    : object_(&object), file_(std::move(file)), path_(std::move(path)), resolved_(resolved), inputs_(std::move(inputs)) {
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
  if (!v.is_number()) failExpected(key, range.describeFor(v), v);
  const double d = v.get<double>();
  if (!range.contains(d)) failExpected(key, range.describeFor(v), v);
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

std::uint64_t JsonReader::unsignedInteger(const std::string& key, std::uint64_t fallback) {
  const Json* v = lookup(key);
  std::uint64_t value = fallback;
  if (v) {
    const std::string expected = "an integer in [0, " + std::to_string(std::numeric_limits<std::uint64_t>::max()) + "]";
    if (v->is_number_unsigned()) {
      value = v->get<std::uint64_t>();
    } else if (v->is_number_float() && std::floor(v->get<double>()) == v->get<double>() && v->get<double>() >= 0.0 &&
               v->get<double>() < 9e15) {
      value = static_cast<std::uint64_t>(v->get<double>());  // 1e5 is an integer too (exactly, below 2^53)
    } else if (v->is_number() && v->get<double>() < 0.0) {
      failExpected(key, "an integer >= 0", *v);
    } else {
      // fractional, or beyond 2^64 - 1 (which the JSON parser reads as a float), or not a number
      failExpected(key, expected, *v);
    }
  }
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

std::string JsonReader::requireInputPath(const std::string& key) {
  const std::string path = resolveInputPath(file_, requireString(key));
  record(key, path);
  return path;
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
      fail(key + "[" + std::to_string(i) + "]", "expected " + range.describeFor(c) + ", got " + describeValue(c));
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
  return JsonReader(v ? *v : kEmpty, file_, pathOf(key), sub, inputs_);
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
    out.emplace_back((*v)[i], file_, p, sub ? &(*sub)[i] : nullptr, inputs_);
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
