// OCamCalib calib_results.txt (Scaramuzza's Matlab toolbox): lines of numbers with '#'
// comments, in order pol, invpol, centre "xc yc" (row, column), affine "c d e", image
// "height width"; converted to the OpenCV frame on reading (OCamModel in models.h).
#include <cmath>
#include <locale>
#include <sstream>

#include "camera_format.h"
#include "scancam/output_file.h"

namespace scancam::camera::detail {
namespace {

bool LooksLikeOCam(const std::string& text) {
  std::istringstream in(text);
  std::string l;
  bool any = false;
  while (std::getline(in, l)) {
    const std::size_t f = l.find_first_not_of(" \t\r");
    if (f == std::string::npos || l[f] == '#') continue;
    if (l.find(':') != std::string::npos || l.find('{') != std::string::npos) return false;
    std::istringstream ls(l);
    std::string tok;
    while (ls >> tok) {
      double v;
      if (!ParseFiniteDouble(tok, &v)) return false;
    }
    any = true;
  }
  return any;
}

}  // namespace

bool SniffOCam(CameraFileContent& file) { return !file.is_json() && LooksLikeOCam(file.text()); }

CameraModel LoadOCam(CameraFileContent& file, const LoadCameraOptions&) {
  const std::string& path = file.path();
  const std::string& text = file.text();
  struct NumLine {
    int no;
    std::vector<double> v;
  };
  std::vector<NumLine> lines;
  std::istringstream in(text);
  std::string l;
  int no = 0;
  while (std::getline(in, l)) {
    ++no;
    const std::size_t f = l.find_first_not_of(" \t\r");
    if (f == std::string::npos || l[f] == '#') continue;
    NumLine nl{no, {}};
    std::istringstream ls(l);
    std::string tok;
    while (ls >> tok) {
      double v;
      if (!ParseFiniteDouble(tok, &v)) {
        throw FileError(path, "line " + std::to_string(no),
                        "expected a number, found '" + tok + "'");
      }
      nl.v.push_back(v);
    }
    if (nl.v.empty()) continue;  // only whitespace (e.g. a vertical tab): a blank line
    lines.push_back(std::move(nl));
  }
  static const char* kWhat[5] = {"direct polynomial 'pol' (length, a0 a1 ...)",
                                 "inverse polynomial 'invpol' (length, coefficients)",
                                 "centre 'xc yc' (row, column)", "affine 'c d e'",
                                 "image size 'height width'"};
  if (lines.size() < 5) {
    throw FileError(path, lines.empty() ? "" : "line " + std::to_string(lines.back().no),
                    "OCamCalib file ends early: missing the " + std::string(kWhat[lines.size()]));
  }
  if (lines.size() > 5) {
    throw FileError(path, "line " + std::to_string(lines[5].no),
                    "unexpected extra numbers after the image size");
  }
  auto poly = [&](int idx, int max_len, int min_len) {
    const NumLine& L = lines[idx];
    const std::string where = "line " + std::to_string(L.no);
    const double nd = L.v[0];
    if (nd != std::floor(nd) || nd < min_len || nd > max_len) {
      throw FileError(path, where,
                      std::string(kWhat[idx]) + ": length " + Num(nd) + " must be an integer in " +
                          std::to_string(min_len) + ".." + std::to_string(max_len));
    }
    const std::size_t n = static_cast<std::size_t>(nd);
    if (L.v.size() != n + 1) {
      throw FileError(path, where,
                      std::string(kWhat[idx]) + ": the length says " + std::to_string(n) +
                          " coefficients but " + std::to_string(L.v.size() - 1) + " follow");
    }
    return std::vector<double>(L.v.begin() + 1, L.v.end());
  };
  OCamParams o;
  o.pol = poly(0, OCamModel::kMaxPol, 1);
  o.invpol = poly(1, OCamModel::kMaxInv, 0);
  auto expect = [&](int idx, std::size_t n) {
    if (lines[idx].v.size() != n) {
      throw FileError(path, "line " + std::to_string(lines[idx].no),
                      std::string(kWhat[idx]) + ": expected " + std::to_string(n) +
                          " numbers, found " + std::to_string(lines[idx].v.size()));
    }
  };
  expect(2, 2);
  expect(3, 3);
  expect(4, 2);
  // The file's centre is (row, column): xc is the ROW. OpenCV u is the column.
  o.center_v = lines[2].v[0];
  o.center_u = lines[2].v[1];
  o.c = lines[3].v[0], o.d = lines[3].v[1], o.e = lines[3].v[2];
  const std::string w_size = "line " + std::to_string(lines[4].no);
  const int hh = ImageSide(path, w_size, lines[4].v[0], kWhat[4]);
  const int ww = ImageSide(path, w_size, lines[4].v[1], kWhat[4]);
  Keys keys;
  keys.width = keys.height = w_size;
  keys.pol = "line " + std::to_string(lines[0].no);
  keys.invpol = "line " + std::to_string(lines[1].no);
  keys.centre = "line " + std::to_string(lines[2].no);
  keys.affine = "line " + std::to_string(lines[3].no);
  return Build(path, CameraType::kOCam, keys,
               [&] { return CameraModel::OCam(o, ww, hh, FileStem(path)); });
}

void SaveOCam(const CameraModel& c, const std::string& path) {
  if (c.type() != CameraType::kOCam) {
    throw FileError(
        path, "",
        std::string("OCamCalib files hold ocam cameras only, not ") + CameraTypeName(c.type()));
  }
  std::ostringstream out;
  out.imbue(std::locale::classic());  // "1920", "0.5" in any locale
  const OCamParams o = c.ocam_params();
  out << "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
         "These are used by cam2world\n\n";
  out << o.pol.size();
  for (double v : o.pol) out << " " << Num(v);
  out << "\n\n#polynomial coefficients for the inverse mapping function (ocam_model.invpol in "
         "MATLAB). These are used by world2cam\n\n";
  out << o.invpol.size();
  for (double v : o.invpol) out << " " << Num(v);
  out << "\n\n#center: \"row\" and \"column\", starting from 0 (C convention)\n\n";
  out << Num(o.center_v) << " " << Num(o.center_u) << "\n\n";
  out << "#affine parameters \"c\", \"d\", \"e\"\n\n";
  out << Num(o.c) << " " << Num(o.d) << " " << Num(o.e) << "\n\n";
  out << "#image size: \"height\" and \"width\"\n\n";
  out << c.height() << " " << c.width() << "\n";
  WriteFileAtomically(path, out.str());
}

}  // namespace scancam::camera::detail
