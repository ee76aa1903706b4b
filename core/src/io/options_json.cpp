// Options structs as JSON parameter files (io/options_json.h).
#include <cmath>
#include <cstdio>
#include <utility>

#include "json_option_reader.h"
#include "scancam/error.h"

namespace scancam::io {
namespace {

std::string Found(const nlohmann::json& j) {
  std::string s = j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  if (s.size() > 40) s = s.substr(0, 40) + "...";
  return s;
}

}  // namespace

void RequireOption(std::vector<OptionProblem>* problems, bool ok, const std::string& key,
                   const std::string& message, double value) {
  if (ok) return;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.10g", value);
  problems->push_back({key, message + ", not " + buf});
}

void ThrowFirstProblem(const std::vector<OptionProblem>& problems, const std::string& source) {
  if (problems.empty()) return;
  throw FileError(source, "", "key '" + problems[0].key + "': " + problems[0].message);
}

JsonOptionReader::JsonOptionReader(const nlohmann::json& j, std::string file, std::string prefix)
    : j_(j), file_(std::move(file)), prefix_(std::move(prefix)) {
  if (!j_.is_object()) {
    throw FileError(file_, "",
                    prefix_.empty()
                        ? "expected a JSON object of options at the top level"
                        : "key '" + prefix_ + "' must be an object, found " + Found(j_));
  }
}

std::string JsonOptionReader::Key(const std::string& key) const {
  return prefix_.empty() ? key : prefix_ + "." + key;
}

void JsonOptionReader::Fail(const std::string& key, const std::string& what) const {
  throw FileError(file_, "", "key '" + Key(key) + "': " + what);
}

void JsonOptionWriter::Fail(const std::string& key, const std::string& what) const {
  throw Error("options key '" + key + "': " + what);
}

const nlohmann::json* JsonOptionReader::Find(const std::string& key) {
  const auto it = j_.find(key);
  if (it == j_.end()) return nullptr;
  used_.insert(key);
  return &*it;
}

void JsonOptionReader::Number(const std::string& key, double* value) {
  const nlohmann::json* v = Find(key);
  if (!v) return;
  if (!v->is_number()) Fail(key, "must be a number, found " + Found(*v));
  const double d = v->get<double>();
  if (!std::isfinite(d)) Fail(key, "must be a finite number");
  *value = d;
}

void JsonOptionReader::Integer(const std::string& key, long long lo, long long hi,
                               long long* value) {
  const nlohmann::json* v = Find(key);
  if (!v) return;
  if (!v->is_number_integer()) Fail(key, "must be a whole number, found " + Found(*v));
  const bool neg = v->is_number_unsigned() ? false : v->get<long long>() < 0;
  const long double d = neg ? static_cast<long double>(v->get<long long>())
                            : static_cast<long double>(v->get<unsigned long long>());
  if (d < lo || d > hi)
    Fail(key,
         "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], not " + Found(*v));
  *value = static_cast<long long>(d);
}

void JsonOptionReader::Bool(const std::string& key, bool* value) {
  const nlohmann::json* v = Find(key);
  if (!v) return;
  if (!v->is_boolean()) Fail(key, "must be true or false, found " + Found(*v));
  *value = v->get<bool>();
}

void JsonOptionReader::String(const std::string& key, std::string* value) {
  const nlohmann::json* v = Find(key);
  if (!v) return;
  if (!v->is_string()) Fail(key, "must be a string, found " + Found(*v));
  *value = v->get<std::string>();
}

void JsonOptionReader::Vector3(const std::string& key, Eigen::Vector3d* value) {
  const nlohmann::json* v = Find(key);
  if (!v) return;
  if (!v->is_array() || v->size() != 3) Fail(key, "must be [x, y, z], found " + Found(*v));
  Eigen::Vector3d out;
  for (int i = 0; i < 3; ++i) {
    const nlohmann::json& e = (*v)[static_cast<std::size_t>(i)];
    if (!e.is_number() || !std::isfinite(e.get<double>()))
      Fail(key, "must be [x, y, z] of finite numbers, found " + Found(*v));
    out[i] = e.get<double>();
  }
  *value = out;
}

void JsonOptionReader::NumberList(const std::string& key, std::vector<double>* value) {
  const nlohmann::json* v = Find(key);
  if (!v) return;
  if (!v->is_array()) Fail(key, "must be an array of numbers, found " + Found(*v));
  std::vector<double> out;
  for (const nlohmann::json& e : *v) {
    if (!e.is_number() || !std::isfinite(e.get<double>()))
      Fail(key, "must be an array of finite numbers, found " + Found(*v));
    out.push_back(e.get<double>());
  }
  *value = std::move(out);
}

void JsonOptionReader::Kind(const std::string& kind) {
  std::string k = kind;
  String("scancam", &k);
  if (k != kind) Fail("scancam", "this file holds '" + k + "', not " + kind);
  long long version = 1;
  Integer("version", 1, 1, &version);
}

void JsonOptionReader::Finish() const {
  for (auto it = j_.begin(); it != j_.end(); ++it)
    if (!used_.count(it.key()))
      Fail(it.key(), "unknown option (check the spelling; see the documentation for the keys)");
}

}  // namespace scancam::io
