// Checks a cloud that CloudCompare coloured with -SCANCAM_COLORIZE (saved as ASCII PLY) against
// the simulator's per-cell truth (truth.csv: row,col,valid,x,y,z,r,g,b,visible).
//
// Usage: cc_colour_check OUT.ply TRUTH.csv [MIN_FRACTION [TOLERANCE]]
// The PLY's vertices are the scan's valid cells in row-major order (CloudCompare's PTX reader
// keeps the file order, and the simulator's PTX is written row-major). A truly visible point
// counts as right when every RGB channel is within TOLERANCE (default 30) of its true colour.
// Passes (exit 0) when at least MIN_FRACTION (default 0.9) of the truly visible points are
// right, the "ScanCam visibility" scalar field is present, and most points the camera cannot
// see are not marked coloured. Prints the numbers either way.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

namespace {

struct TruthCell {
  bool valid = false, visible = false;
  double r = 0, g = 0, b = 0;
};

[[noreturn]] void Fail(const std::string& msg) {
  std::cerr << "cc_colour_check: " << msg << "\n";
  std::exit(1);
}

std::vector<TruthCell> ReadTruth(const std::string& path) {
  std::ifstream in(path);
  if (!in) Fail(path + ": cannot open");
  std::string line;
  std::getline(in, line);  // header
  std::vector<TruthCell> cells;
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string item;
    while (std::getline(ss, item, ',')) f.push_back(item);
    if (f.size() != 10) Fail(path + ": expected 10 fields in '" + line + "'");
    TruthCell c;
    c.valid = f[2] == "1";
    c.visible = f[9] == "1";
    if (c.valid) {
      c.r = std::atof(f[6].c_str());
      c.g = std::atof(f[7].c_str());
      c.b = std::atof(f[8].c_str());
    }
    cells.push_back(c);
  }
  return cells;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) Fail("usage: cc_colour_check OUT.ply TRUTH.csv [MIN_FRACTION [TOLERANCE]]");
  const double min_fraction = argc > 3 ? std::atof(argv[3]) : 0.9;
  const double tolerance = argc > 4 ? std::atof(argv[4]) : 30.0;
  const std::vector<TruthCell> truth = ReadTruth(argv[2]);
  std::vector<const TruthCell*> valid;
  for (const auto& c : truth)
    if (c.valid) valid.push_back(&c);

  std::ifstream ply(argv[1]);
  if (!ply) Fail(std::string(argv[1]) + ": cannot open");
  std::string line;
  std::getline(ply, line);
  if (line.rfind("ply", 0) != 0) Fail("not a PLY file");
  long vertices = -1;
  std::vector<std::string> props;
  bool in_vertex = false;
  while (std::getline(ply, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::stringstream ss(line);
    std::string word;
    ss >> word;
    if (word == "format" && line.find("ascii") == std::string::npos)
      Fail("the PLY must be ASCII (-PLY_EXPORT_FMT ASCII)");
    if (word == "element") {
      std::string name;
      long n = 0;
      ss >> name >> n;
      in_vertex = name == "vertex";
      if (in_vertex) vertices = n;
    } else if (word == "property" && in_vertex) {
      std::string type, name;
      ss >> type >> name;
      props.push_back(name);
    } else if (word == "end_header") {
      break;
    }
  }
  auto col = [&](const std::string& name) {
    for (std::size_t i = 0; i < props.size(); ++i)
      if (props[i] == name) return static_cast<int>(i);
    return -1;
  };
  const int ir = col("red"), ig = col("green"), ib = col("blue");
  int ivis = -1;
  for (std::size_t i = 0; i < props.size(); ++i)
    if (props[i].find("ScanCam_visibility") != std::string::npos) ivis = static_cast<int>(i);
  if (ir < 0 || ig < 0 || ib < 0) Fail("the PLY has no red/green/blue properties");
  if (ivis < 0) Fail("the PLY has no 'ScanCam visibility' scalar field");
  if (vertices != static_cast<long>(valid.size()))
    Fail("the PLY has " + std::to_string(vertices) + " vertices but the truth has " +
         std::to_string(valid.size()) + " valid cells");

  std::size_t visible = 0, right = 0, hidden = 0, hidden_marked_coloured = 0;
  double sum_err = 0;
  for (long k = 0; k < vertices; ++k) {
    if (!std::getline(ply, line)) Fail("the PLY ends early");
    std::stringstream ss(line);
    std::vector<double> v;
    double x;
    while (ss >> x) v.push_back(x);
    if (v.size() < props.size()) Fail("short vertex line " + std::to_string(k));
    const TruthCell& t = *valid[static_cast<std::size_t>(k)];
    const double state = v[static_cast<std::size_t>(ivis)];
    if (t.visible) {
      ++visible;
      const double e =
          std::max({std::abs(v[ir] - t.r), std::abs(v[ig] - t.g), std::abs(v[ib] - t.b)});
      sum_err += e;
      if (e <= tolerance && state == 3) ++right;
    } else {
      ++hidden;
      if (state == 3) ++hidden_marked_coloured;
    }
  }
  const double frac = visible ? double(right) / double(visible) : 0.0;
  const double wrong_hidden = hidden ? double(hidden_marked_coloured) / double(hidden) : 0.0;
  std::printf(
      "%zu points; %zu truly visible: %.1f %% coloured within %.0f of the true colour (mean "
      "max-channel error %.1f); %zu not visible: %.1f %% wrongly marked coloured\n",
      valid.size(), visible, 100.0 * frac, tolerance, visible ? sum_err / double(visible) : 0.0,
      hidden, 100.0 * wrong_hidden);
  if (visible == 0) Fail("no truly visible point");
  if (frac < min_fraction) Fail("too few points have the right colour");
  if (wrong_hidden > 0.1) Fail("too many hidden points were coloured");
  return 0;
}
