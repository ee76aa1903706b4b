// ScanCam (private): an options struct <-> a JSON object, key by key (the file format is in
// scancam/io/options_json.h). A module lists its keys once, in a function template
//   template <class V> void VisitKeys(V& v, Options& o) { v.Kind(..); v.Number("key", &o.key);
//                                                         v.Object("sub", [&](V& s) {..}); }
// run with a JsonOptionWriter (struct -> JSON) or a JsonOptionReader (JSON -> struct), so the
// two directions cannot disagree.
#pragma once

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

#include "scancam/io/options_json.h"

namespace scancam::io {

/// Reads the members of one JSON object into a struct's fields (absent keys leave the field as
/// it is), remembering which keys were used; Finish() throws for the others. Errors:
/// FileError(file, "", "key 'PREFIX.KEY': ...").
class JsonOptionReader {
 public:
  /// Throws when `j` is not an object. `prefix` ("" at the top level) prefixes key names.
  JsonOptionReader(const nlohmann::json& j, std::string file, std::string prefix = "");
  void Number(const std::string& key, double* value);
  void Integer(const std::string& key, long long lo, long long hi, long long* value);
  void Bool(const std::string& key, bool* value);
  void String(const std::string& key, std::string* value);
  void Vector3(const std::string& key, Eigen::Vector3d* value);
  /// An array of finite numbers (any length; the module's Validate checks it).
  void NumberList(const std::string& key, std::vector<double>* value);
  /// A nested object: when present, `visit` reads it with its own reader (then Finish()).
  template <class F>
  void Object(const std::string& key, F&& visit) {
    if (const nlohmann::json* v = Find(key)) {
      JsonOptionReader sub(*v, file_, Key(key));
      visit(sub);
      sub.Finish();
    }
  }
  /// The kind marker: when "scancam" is present it must equal `kind`; "version" must be 1.
  void Kind(const std::string& kind);
  /// Throws "key 'PREFIX.KEY': what" (e.g. a string value that is not one of the names).
  [[noreturn]] void Fail(const std::string& key, const std::string& what) const;
  /// Throws naming the first key that was not read.
  void Finish() const;

 private:
  std::string Key(const std::string& key) const;
  const nlohmann::json* Find(const std::string& key);
  const nlohmann::json& j_;
  std::string file_, prefix_;
  std::set<std::string> used_;
};

/// Writes a struct's fields as the members of one JSON object, in the order visited.
class JsonOptionWriter {
 public:
  void Number(const std::string& key, const double* value) { j_[key] = *value; }
  void Integer(const std::string& key, long long, long long, const long long* value) {
    j_[key] = *value;
  }
  void Bool(const std::string& key, const bool* value) { j_[key] = *value; }
  void String(const std::string& key, const std::string* value) { j_[key] = *value; }
  void Vector3(const std::string& key, const Eigen::Vector3d* value) {
    j_[key] = {value->x(), value->y(), value->z()};
  }
  void NumberList(const std::string& key, const std::vector<double>* value) { j_[key] = *value; }
  template <class F>
  void Object(const std::string& key, F&& visit) {
    JsonOptionWriter sub;
    visit(sub);
    j_[key] = sub.j_;
  }
  void Kind(const std::string& kind) {
    j_["scancam"] = kind;
    j_["version"] = 1;
  }
  [[noreturn]] void Fail(const std::string& key, const std::string& what) const;
  /// Pretty-printed (2-space indent), trailing newline.
  std::string Text() const { return j_.dump(2) + "\n"; }

 private:
  nlohmann::ordered_json j_ = nlohmann::ordered_json::object();
};

/// Options of type T from JSON `j` (`source` names it): `base` with the keys present replaced
/// (visit_keys(reader, options)), unknown keys refused, then the module's Validate (the first
/// problem thrown naming `source` and the key).
template <class T, class VisitKeys, class Validate>
T OptionsFromJson(const nlohmann::json& j, const std::string& source, const T& base,
                  VisitKeys&& visit_keys, Validate&& validate) {
  T o = base;
  JsonOptionReader r(j, source);
  visit_keys(r, o);
  r.Finish();
  ThrowFirstProblem(validate(o), source);
  return o;
}

/// The JSON text of options of type T (visit_keys(writer, copy)).
template <class T, class VisitKeys>
std::string OptionsToJson(const T& options, VisitKeys&& visit_keys) {
  T copy = options;
  JsonOptionWriter w;
  visit_keys(w, copy);
  return w.Text();
}

}  // namespace scancam::io
