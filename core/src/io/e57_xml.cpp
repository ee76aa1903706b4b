// E57 XML model: the typed XML tree (pugixml) read into the file's scans, prototypes and images.
#include <algorithm>
#include <cctype>
#include <string_view>

#include "e57_detail.h"

namespace scancam::io::e57_detail {

namespace {

std::string NodePath(const pugi::xml_node& n) {
  std::string p;
  for (pugi::xml_node k = n; k && k.type() == pugi::node_element; k = k.parent()) {
    std::string name = k.name();
    if (name == "vectorChild") {
      int idx = 0;
      for (pugi::xml_node s = k.previous_sibling(); s; s = s.previous_sibling()) {
        if (s.type() == pugi::node_element) ++idx;
      }
      name = std::to_string(idx);
    }
    p = "/" + name + p;
  }
  return p;
}

// Typed access to the XML tree; errors name the element's path.
class Xml {
 public:
  explicit Xml(const std::string& path) : path_(path) {}

  [[noreturn]] void Fail(const pugi::xml_node& n, const std::string& what) const {
    throw FileError(path_, "XML " + NodePath(n), what);
  }

  std::string Type(const pugi::xml_node& n) const { return n.attribute("type").value(); }

  // An element's or attribute's number; empty text is 0 (E57 writes defaults that way).
  static std::string_view Trimmed(const char* s) {
    std::string_view t(s);
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.front()))) t.remove_prefix(1);
    while (!t.empty() && std::isspace(static_cast<unsigned char>(t.back()))) t.remove_suffix(1);
    return t;
  }
  static bool ParseLL(const char* s, long long& v) {
    const std::string_view t = Trimmed(s);
    v = 0;
    return t.empty() || io::detail::ParseInt64(t, v);
  }
  static bool ParseD(const char* s, double& v) {
    const std::string_view t = Trimmed(s);
    v = 0;
    return t.empty() || io::detail::ParseDouble(t, v);
  }

  long long AttrInt(const pugi::xml_node& n, const char* name, long long fallback) const {
    pugi::xml_attribute a = n.attribute(name);
    if (!a) return fallback;
    long long v = 0;
    if (!ParseLL(a.value(), v)) {
      Fail(n,
           std::string("attribute ") + name + ": expected an integer, found " + Quote(a.value()));
    }
    return v;
  }
  double AttrDouble(const pugi::xml_node& n, const char* name, double fallback) const {
    pugi::xml_attribute a = n.attribute(name);
    if (!a) return fallback;
    double v = 0;
    if (!ParseD(a.value(), v) || !std::isfinite(v)) {
      Fail(n, std::string("attribute ") + name + ": expected a finite number, found " +
                  Quote(a.value()));
    }
    return v;
  }

  // A numeric element's value: Integer, Float or ScaledInteger (scaled).
  double Number(const pugi::xml_node& n) const {
    const std::string type = Type(n);
    if (type == "Integer") {
      long long v = 0;
      if (!ParseLL(n.text().get(), v))
        Fail(n, "expected an integer, found " + Quote(n.text().get()));
      return static_cast<double>(v);
    }
    if (type == "ScaledInteger") {
      long long v = 0;
      if (!ParseLL(n.text().get(), v))
        Fail(n, "expected an integer, found " + Quote(n.text().get()));
      return static_cast<double>(v) * AttrDouble(n, "scale", 1.0) + AttrDouble(n, "offset", 0.0);
    }
    if (type == "Float") {
      double v = 0;
      if (!ParseD(n.text().get(), v) || std::isnan(v))
        Fail(n, "expected a number, found " + Quote(n.text().get()));
      return v;
    }
    Fail(n, "expected a number (Integer, Float or ScaledInteger), found type " + Quote(type));
  }
  double ChildNumber(const pugi::xml_node& parent, const char* name, double fallback) const {
    pugi::xml_node c = parent.child(name);
    return c ? Number(c) : fallback;
  }
  std::string ChildString(const pugi::xml_node& parent, const char* name) const {
    return parent.child(name).text().get();
  }

  E57Pose Pose(const pugi::xml_node& parent) const {
    E57Pose pose;
    pugi::xml_node p = parent.child("pose");
    if (!p) return pose;
    pose.present = true;
    if (pugi::xml_node r = p.child("rotation")) {
      const double w = ChildNumber(r, "w", 1.0), x = ChildNumber(r, "x", 0.0),
                   y = ChildNumber(r, "y", 0.0), z = ChildNumber(r, "z", 0.0);
      Eigen::Quaterniond q(w, x, y, z);
      const double norm = q.norm();
      if (!(norm > 1e-12) || !std::isfinite(norm))
        Fail(r, "the rotation quaternion is zero or not finite");
      pose.rotation = Eigen::Quaterniond(q.coeffs() / norm);
    }
    if (pugi::xml_node t = p.child("translation")) {
      pose.translation = Eigen::Vector3d(ChildNumber(t, "x", 0.0), ChildNumber(t, "y", 0.0),
                                         ChildNumber(t, "z", 0.0));
      if (!pose.translation.allFinite() ||
          pose.translation.cwiseAbs().maxCoeff() > kMaxCoordinate_m)
        Fail(t, "the translation is not finite or beyond 1e9 m");
    }
    return pose;
  }

 private:
  std::string path_;
};

}  // namespace

int BitsFor(long long minimum, long long maximum) {
  const std::uint64_t range =
      static_cast<std::uint64_t>(maximum) - static_cast<std::uint64_t>(minimum);
  int bits = 0;
  while (bits < 64 && (range >> bits) != 0) ++bits;
  return bits;
}

namespace {

void ReadPrototype(const Xml& xml, const pugi::xml_node& node, const std::string& prefix,
                   std::vector<Field>& fields) {
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling()) {
    if (c.type() != pugi::node_element) continue;
    const std::string type = xml.Type(c);
    Field f;
    f.name = prefix + c.name();
    if (type == "Structure") {
      ReadPrototype(xml, c, f.name + "/", fields);
      continue;
    }
    if (type == "Float") {
      const std::string precision = c.attribute("precision").value();
      if (!precision.empty() && precision != "single" && precision != "double")
        xml.Fail(c, "precision must be single or double, found " + Quote(precision));
      f.single = precision == "single";
      f.bits = f.single ? 32 : 64;
    } else if (type == "Integer" || type == "ScaledInteger") {
      f.kind = type == "Integer" ? Field::kInteger : Field::kScaled;
      f.minimum = xml.AttrInt(c, "minimum", std::numeric_limits<long long>::min());
      f.maximum = xml.AttrInt(c, "maximum", std::numeric_limits<long long>::max());
      if (f.minimum > f.maximum) {
        xml.Fail(c, "minimum " + std::to_string(f.minimum) + " is greater than maximum " +
                        std::to_string(f.maximum));
      }
      f.bits = BitsFor(f.minimum, f.maximum);
      if (f.kind == Field::kScaled) {
        f.scale = xml.AttrDouble(c, "scale", 1.0);
        f.offset = xml.AttrDouble(c, "offset", 0.0);
        if (f.scale == 0.0) xml.Fail(c, "scale is 0");
      }
    } else {
      xml.Fail(c, "unsupported point field type " + Quote(type) +
                      " (this reader knows Float, Integer and ScaledInteger)");
    }
    fields.push_back(f);
  }
}

// Leica's distortion extension: children named PREFIX:CameraNumber, PREFIX:Type, PREFIX:CV_*.
void ReadLeicaDistortion(const Xml& xml, const pugi::xml_node& node, E57LeicaDistortion& d) {
  for (pugi::xml_node c = node.first_child(); c; c = c.next_sibling()) {
    if (c.type() != pugi::node_element) continue;
    std::string n = c.name();
    const std::size_t colon = n.find(':');
    if (colon != std::string::npos) n = n.substr(colon + 1);
    double* target = nullptr;
    if (n == "Type") {
      d.type = c.text().get();
      continue;
    }
    if (n == "CameraNumber") {
      d.camera_number = static_cast<long long>(xml.Number(c));
      continue;
    }
    if (n == "CV_WIDTH" || n == "CV_HEIGHT") {
      const double v = xml.Number(c);
      if (v < 0 || v > 1e9) xml.Fail(c, "expected an image size in pixels");
      (n == "CV_WIDTH" ? d.width_px : d.height_px) = static_cast<long long>(v);
      continue;
    }
    if (n.size() == 5 && n.compare(0, 4, "CV_K") == 0 && n[4] >= '1' && n[4] <= '6') {
      target = &d.k[n[4] - '1'];
    } else if (n == "CV_P1" || n == "CV_P2") {
      target = &d.p[n[4] - '1'];
    } else if (n == "CV_FX") {
      target = &d.fx_px;
    } else if (n == "CV_FY") {
      target = &d.fy_px;
    } else if (n == "CV_CX") {
      target = &d.cx_px;
    } else if (n == "CV_CY") {
      target = &d.cy_px;
    }
    if (!target) {
      d.unknown.push_back(n);
      continue;
    }
    *target = xml.Number(c);
  }
}

bool Has(const std::vector<Field>& f, const char* name) {
  return std::any_of(f.begin(), f.end(), [&](const Field& x) { return x.name == name; });
}

}  // namespace

ParsedFile Parse(PagedFile& file) {
  ParsedFile pf;
  pf.header = ReadHeader(file);
  const Header& h = pf.header;
  pf.info.version_major = static_cast<int>(h.major);
  pf.info.version_minor = static_cast<int>(h.minor);
  pf.info.file_bytes = file.physical_size();
  const std::uint64_t xml_logical = file.ToLogical(h.xml_offset, "the XML section (header)");
  if (h.xml_length == 0 || h.xml_length > file.logical_size() - xml_logical ||
      h.xml_length > kMaxXmlBytes) {
    throw FileError(
        file.path(), "byte 32",
        "the XML section's length " + std::to_string(h.xml_length) + " does not fit in the file (" +
            std::to_string(file.logical_size() - xml_logical) + " data bytes from its start)");
  }
  std::string text(static_cast<std::size_t>(h.xml_length), '\0');
  file.Read(xml_logical, text.data(), text.size(), "the XML section");
  pugi::xml_document doc;
  const pugi::xml_parse_result res =
      doc.load_buffer(text.data(), text.size(), pugi::parse_default, pugi::encoding_utf8);
  if (!res) {
    throw FileError(file.path(), "XML byte " + std::to_string(res.offset),
                    std::string("the XML section is not well-formed: ") + res.description());
  }
  Xml xml(file.path());
  pugi::xml_node root = doc.child("e57Root");
  if (!root) {
    throw FileError(file.path(), "XML", "the XML section has no e57Root element");
  }
  pf.info.library = xml.ChildString(root, "e57LibraryVersion");

  for (pugi::xml_node s = root.child("data3D").first_child(); s; s = s.next_sibling()) {
    if (s.type() != pugi::node_element) continue;
    ScanDesc d;
    E57ScanInfo& si = d.info;
    si.name = xml.ChildString(s, "name");
    si.guid = xml.ChildString(s, "guid");
    si.description = xml.ChildString(s, "description");
    si.pose = xml.Pose(s);
    pugi::xml_node points = s.child("points");
    if (!points) xml.Fail(s, "the scan has no points element");
    if (xml.Type(points) != "CompressedVector")
      xml.Fail(points, "expected a CompressedVector, found type " + Quote(xml.Type(points)));
    const long long count = xml.AttrInt(points, "recordCount", -1);
    if (count < 0) xml.Fail(points, "recordCount is missing or negative");
    si.record_count = static_cast<std::uint64_t>(count);
    const long long offset = xml.AttrInt(points, "fileOffset", -1);
    if (offset < 0) xml.Fail(points, "fileOffset is missing or negative");
    d.section_offset = static_cast<std::uint64_t>(offset);
    pugi::xml_node proto = points.child("prototype");
    if (!proto) xml.Fail(points, "the compressed vector has no prototype");
    ReadPrototype(xml, proto, "", d.fields);
    if (d.fields.empty()) xml.Fail(proto, "the prototype has no field");
    for (pugi::xml_node c = points.child("codecs").first_child(); c; c = c.next_sibling()) {
      if (c.type() == pugi::node_element && !c.child("bitPackCodec")) {
        xml.Fail(c, "unsupported codec (this reader knows only the default bitPackCodec)");
      }
    }
    for (const Field& f : d.fields) si.fields.push_back(f.name);
    const auto& fl = d.fields;
    si.cartesian = Has(fl, "cartesianX") && Has(fl, "cartesianY") && Has(fl, "cartesianZ");
    si.spherical =
        Has(fl, "sphericalRange") && Has(fl, "sphericalAzimuth") && Has(fl, "sphericalElevation");
    if (!si.cartesian && !si.spherical) {
      xml.Fail(proto,
               "the prototype has neither cartesianX/Y/Z nor sphericalRange/Azimuth/Elevation");
    }
    si.has_intensity = Has(fl, "intensity");
    si.has_colour = Has(fl, "colorRed") && Has(fl, "colorGreen") && Has(fl, "colorBlue");
    si.has_grid_index = Has(fl, "rowIndex") && Has(fl, "columnIndex");
    if (pugi::xml_node b = s.child("indexBounds")) {
      si.has_index_bounds = true;
      si.row_min = ToIndex(xml.ChildNumber(b, "rowMinimum", 0));
      si.row_max = ToIndex(xml.ChildNumber(b, "rowMaximum", 0));
      si.column_min = ToIndex(xml.ChildNumber(b, "columnMinimum", 0));
      si.column_max = ToIndex(xml.ChildNumber(b, "columnMaximum", 0));
    }
    if (pugi::xml_node l = s.child("intensityLimits")) {
      si.has_intensity_limits = true;
      si.intensity_min = xml.ChildNumber(l, "intensityMinimum", 0.0);
      si.intensity_max = xml.ChildNumber(l, "intensityMaximum", 0.0);
    }
    pf.info.scans.push_back(si);
    pf.scans.push_back(std::move(d));
  }

  for (pugi::xml_node m = root.child("images2D").first_child(); m; m = m.next_sibling()) {
    if (m.type() != pugi::node_element) continue;
    E57ImageInfo im;
    im.name = xml.ChildString(m, "name");
    im.guid = xml.ChildString(m, "guid");
    im.description = xml.ChildString(m, "description");
    im.associated_scan_guid = xml.ChildString(m, "associatedData3DGuid");
    for (std::size_t k = 0; k < pf.info.scans.size(); ++k) {
      if (!im.associated_scan_guid.empty() && pf.info.scans[k].guid == im.associated_scan_guid)
        im.associated_scan = static_cast<int>(k);
    }
    im.pose = xml.Pose(m);
    for (const char* rep : {"pinholeRepresentation", "sphericalRepresentation",
                            "cylindricalRepresentation", "visualReferenceRepresentation"}) {
      pugi::xml_node r = m.child(rep);
      if (!r) continue;
      std::string name = rep;
      im.representation = name.substr(0, name.size() - std::string("Representation").size());
      pugi::xml_node blob = r.child("jpegImage");
      im.blob_type = "jpeg";
      if (!blob) {
        blob = r.child("pngImage");
        im.blob_type = "png";
      }
      if (!blob) xml.Fail(r, "the representation has neither jpegImage nor pngImage");
      const long long off = xml.AttrInt(blob, "fileOffset", -1);
      const long long len = xml.AttrInt(blob, "length", -1);
      if (off < 0 || len < 0) xml.Fail(blob, "fileOffset or length missing or negative");
      im.blob_offset = static_cast<std::uint64_t>(off);
      im.blob_length = static_cast<std::uint64_t>(len);
      im.has_mask = static_cast<bool>(r.child("imageMask"));
      im.width_px = ToIndex(xml.ChildNumber(r, "imageWidth", 0));
      im.height_px = ToIndex(xml.ChildNumber(r, "imageHeight", 0));
      im.pixel_width_m = xml.ChildNumber(r, "pixelWidth", 0.0);
      im.pixel_height_m = xml.ChildNumber(r, "pixelHeight", 0.0);
      im.focal_length_m = xml.ChildNumber(r, "focalLength", 0.0);
      im.principal_x_px = xml.ChildNumber(r, "principalPointX", 0.0);
      im.principal_y_px = xml.ChildNumber(r, "principalPointY", 0.0);
      im.radius_m = xml.ChildNumber(r, "radius", 0.0);
      break;
    }
    for (pugi::xml_node c = m.first_child(); c; c = c.next_sibling()) {
      const std::string n = c.name();
      if (n.size() > 11 && n.compare(n.size() - 11, 11, ":distortion") == 0) {
        im.has_leica_distortion = true;
        ReadLeicaDistortion(xml, c, im.leica);
      }
    }
    pf.info.images.push_back(im);
  }
  return pf;
}

}  // namespace scancam::io::e57_detail
