// ScanCam internal: the bounded YAML reader behind the camera file formats (camera_format.h).
//
// A small reader for the YAML subset Kalibr, ROS and OpenCV write: block mappings by
// indentation, block sequences ("- item", also at the parent key's indentation), flow sequences /
// mappings that may span lines, plain and quoted scalars, comments, and node tags (OpenCV's
// "!!opencv-matrix"), which are skipped. OpenCV's own YAML parser rejects valid files of both
// tools (no "%YAML" header, "- [...]" at the key's indentation) and never returned on a damaged
// file (fuzz/FINDINGS.md #13), hence this reader, which also reads OpenCV's own YAML. yaml-cpp
// (Debian's libyaml-cpp 0.7) was measured as a replacement and not taken: see
// docs/design/camera-yaml.md. Bounded: at most 20000 lines and 64 levels of nesting; every node
// remembers its line for error messages ("FILE:line N: what").
#pragma once

#include <cmath>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "scancam/error.h"

namespace scancam::camera::detail {

bool ParseFiniteDouble(const std::string& token, double* v);  // camera_format.h

/// A parsed YAML (or JSON) value: null, scalar text, sequence or mapping (keys in file order).
struct YNode {
  enum Kind { kNull, kScalar, kSeq, kMap } kind = kNull;
  std::string scalar;
  std::vector<YNode> seq;
  std::vector<std::pair<std::string, YNode>> map;
  int line = 0;

  const YNode* Find(const std::string& key) const {
    for (const auto& kv : map) {
      if (kv.first == key) return &kv.second;
    }
    return nullptr;
  }
};

/// Parses `text` (the content of `file`). Throws FileError ("FILE:line N: what") for anything
/// outside the subset, duplicate keys, tabs used for indentation, more than 20000 lines or
/// nesting deeper than 64 levels.
YNode ParseYaml(const std::string& file, const std::string& text);

/// A JSON value as a YNode (numbers as text with 17 significant digits, line 0). Nesting is
/// bounded (64 levels).
YNode JsonToYNode(const std::string& path, const nlohmann::json& j, int depth = 0);

/// Field access with errors naming file, line and field.
class YFields {
 public:
  YFields(const std::string& file, const YNode& node, std::string prefix)
      : file_(file), node_(node), prefix_(std::move(prefix)) {}

  const YNode* Opt(const std::string& key) const { return node_.Find(key); }
  const YNode& Req(const std::string& key) const {
    const YNode* n = node_.Find(key);
    if (!n) throw FileError(file_, Field(key), "missing field");
    return *n;
  }
  std::string Field(const std::string& key) const { return prefix_ + key; }
  std::string Where(const YNode& n, const std::string& key) const {
    return "line " + std::to_string(n.line) + ": " + Field(key);
  }
  std::string String(const std::string& key) const {
    const YNode& n = Req(key);
    if (n.kind != YNode::kScalar) throw FileError(file_, Where(n, key), "expected a text value");
    return n.scalar;
  }
  double Number(const YNode& n, const std::string& key) const {
    double v;
    if (n.kind != YNode::kScalar || !ParseFiniteDouble(n.scalar, &v)) {
      throw FileError(
          file_, Where(n, key),
          "expected a number, found '" + (n.kind == YNode::kScalar ? n.scalar : "") + "'");
    }
    return v;
  }
  int Int(const std::string& key) const {
    const YNode& n = Req(key);
    const double v = Number(n, key);
    if (v != std::floor(v) || std::abs(v) > 1e9) {
      throw FileError(file_, Where(n, key), "expected an integer, found '" + n.scalar + "'");
    }
    return static_cast<int>(v);
  }
  // A flat list of numbers (nested lists are flattened: OpenCalib writes [[...], [...]]).
  std::vector<double> Numbers(const YNode& n, const std::string& key) const {
    std::vector<double> out;
    Flatten(n, key, &out);
    return out;
  }
  std::vector<double> Numbers(const std::string& key) const { return Numbers(Req(key), key); }

 private:
  void Flatten(const YNode& n, const std::string& key, std::vector<double>* out) const {
    if (n.kind == YNode::kSeq) {
      for (const auto& c : n.seq) Flatten(c, key, out);
    } else {
      if (n.kind != YNode::kScalar) throw FileError(file_, Where(n, key), "expected a list");
      out->push_back(Number(n, key));
    }
  }

  const std::string& file_;
  const YNode& node_;
  std::string prefix_;
};

}  // namespace scancam::camera::detail
