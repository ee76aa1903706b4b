// ASTM E57 writer: one scan as a compressed vector of single-precision Cartesian points (with
// intensity, colour and the grid's row / column), the XML last, every page CRC-checked.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <sstream>

#include "e57_detail.h"
#include "scancam/error.h"
#include "scancam/io/e57.h"
#include "scancam/output_file.h"

namespace scancam::io {

using namespace e57_detail;

namespace {

void PutLe(std::vector<std::uint8_t>& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}

// Appends `bits`-bit values, least significant bit first, continuing across calls.
struct BitPacker {
  std::vector<std::uint8_t> bytes;
  std::uint64_t acc = 0;
  int fill = 0;
  void Put(std::uint64_t v, int bits) {
    if (bits == 0) return;
    acc |= v << fill;
    fill += bits;
    while (fill >= 8) {
      bytes.push_back(static_cast<std::uint8_t>(acc));
      acc >>= 8;
      fill -= 8;
    }
  }
  void Finish() {
    if (fill > 0) bytes.push_back(static_cast<std::uint8_t>(acc));
    acc = 0;
    fill = 0;
  }
};

std::string XmlNumber(double v) {
  std::string s;
  io::detail::AppendNumber(s, v);
  return s;
}

}  // namespace

void WriteE57(const std::string& path, const OrderedScan& scan,
              const std::vector<std::array<std::uint8_t, 3>>* rgb,
              const std::vector<std::uint8_t>* coloured, const Progress& progress,
              const std::vector<E57ImageToWrite>* images) {
  CheckScan(scan, scan.source.empty() ? std::string("scan") : scan.source);
  if ((rgb && rgb->size() != scan.size()) || (coloured && coloured->size() != scan.size())) {
    throw FileError(path, "", "colours do not match the scan's grid");
  }
  // Pre-pass: the records, bounds and limits (the XML is written last but its offset and the
  // section's length go into the header first, so every size is known before writing).
  std::size_t records = 0;  // valid cells, written in grid order (no list of them: 100 M fit)
  double imin = std::numeric_limits<double>::infinity(), imax = -imin;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(imax), hi = Eigen::Vector3d::Constant(imin);
  for (std::size_t k = 0; k < scan.size(); ++k) {
    if (!scan.valid(k)) continue;
    ++records;
    lo = lo.cwiseMin(scan.point_m[k].cast<double>());
    hi = hi.cwiseMax(scan.point_m[k].cast<double>());
    if (scan.has_intensity()) {
      const double v = scan.intensity[k];
      if (std::isfinite(v)) {
        imin = std::min(imin, v);
        imax = std::max(imax, v);
      }
    }
  }
  if (records == 0) throw FileError(path, "", "the scan has no valid point to write");
  const bool intensity = scan.has_intensity();
  const bool colour = rgb != nullptr;
  const int row_bits = BitsFor(0, scan.rows - 1), col_bits = BitsFor(0, scan.cols - 1);
  // Streams: x y z [intensity isIntensityInvalid] [r g b isColorInvalid] row column.
  constexpr std::size_t kPerPacket = 2048;  // a multiple of 8: bit-packed chunks end on bytes
  const int streams = 3 + (intensity ? 2 : 0) + (colour ? 4 : 0) + 2;
  auto packet_bytes = [&](std::size_t n) {
    std::uint64_t b = 6 + 2 * std::uint64_t(streams) + 12 * n;
    auto packed = [&](int bits) { return (std::uint64_t(bits) * n + 7) / 8; };
    if (intensity) b += 4 * n + packed(1);
    if (colour) b += 3 * n + packed(1);
    b += packed(row_bits) + packed(col_bits);
    return (b + 3) / 4 * 4;
  };
  std::uint64_t data_bytes = 0;
  for (std::size_t done = 0; done < records; done += kPerPacket)
    data_bytes += packet_bytes(std::min(kPerPacket, records - done));
  const std::uint64_t section_logical = 48, section_length = 32 + data_bytes;
  // Image blobs after the points: a 16-byte section header, the bytes, zeros up to 4 bytes.
  std::vector<std::uint64_t> blob_logical;
  std::uint64_t blobs_end = section_logical + section_length;
  if (images) {
    for (const E57ImageToWrite& im : *images) {
      const std::string& rep = im.info.representation;
      if ((rep != "pinhole" && rep != "spherical") ||
          (im.info.blob_type != "jpeg" && im.info.blob_type != "png") || im.bytes.empty()) {
        throw FileError(
            path, "",
            "image '" + im.info.name + "': only pinhole or spherical JPEG/PNG images are written");
      }
      blob_logical.push_back(blobs_end);
      blobs_end += (16 + im.bytes.size() + 3) / 4 * 4;
    }
  }
  const std::uint64_t xml_logical = blobs_end;

  if (!(imin <= imax)) imin = imax = 0.0;
  const bool unit = imin >= 0.0 && imax <= 1.0;
  std::ostringstream x;
  x.precision(17);
  x << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
       "<e57Root type=\"Structure\" xmlns=\"http://www.astm.org/COMMIT/E57/2010-e57-v1.0\"\n"
       "         xmlns:dist=\"http://www.libe57.org/E57_LEICA_Camera_Distortion.txt\">\n"
       "  <formatName type=\"String\"><![CDATA[ASTM E57 3D Imaging Data File]]></formatName>\n"
       "  <guid type=\"String\"><![CDATA[{scancam-file-"
    << records << "-" << scan.rows << "x" << scan.cols
    << "}]]></guid>\n"
       "  <versionMajor type=\"Integer\">1</versionMajor>\n"
       "  <versionMinor type=\"Integer\">0</versionMinor>\n"
       "  <e57LibraryVersion type=\"String\"><![CDATA[ScanCam]]></e57LibraryVersion>\n"
       "  <coordinateMetadata type=\"String\"/>\n"
       "  <data3D type=\"Vector\" allowHeterogeneousChildren=\"1\">\n"
       "    <vectorChild type=\"Structure\">\n"
       "      <guid type=\"String\"><![CDATA[{scancam-scan-"
    << records << "-" << scan.rows << "x" << scan.cols
    << "}]]></guid>\n"
       "      <name type=\"String\"><![CDATA[ScanCam scan]]></name>\n"
       "      <pose type=\"Structure\"><rotation type=\"Structure\"><w type=\"Float\">1</w>"
       "<x type=\"Float\">0</x><y type=\"Float\">0</y><z type=\"Float\">0</z></rotation>"
       "<translation type=\"Structure\"><x type=\"Float\">0</x><y type=\"Float\">0</y>"
       "<z type=\"Float\">0</z></translation></pose>\n"
       "      <indexBounds type=\"Structure\"><rowMinimum type=\"Integer\">0</rowMinimum>"
       "<rowMaximum type=\"Integer\">"
    << scan.rows - 1
    << "</rowMaximum><columnMinimum type=\"Integer\">0</columnMinimum>"
       "<columnMaximum type=\"Integer\">"
    << scan.cols - 1
    << "</columnMaximum><returnMinimum type=\"Integer\">0</returnMinimum>"
       "<returnMaximum type=\"Integer\">0</returnMaximum></indexBounds>\n"
       "      <cartesianBounds type=\"Structure\"><xMinimum type=\"Float\">"
    << XmlNumber(lo.x()) << "</xMinimum><xMaximum type=\"Float\">" << XmlNumber(hi.x())
    << "</xMaximum><yMinimum type=\"Float\">" << XmlNumber(lo.y())
    << "</yMinimum><yMaximum type=\"Float\">" << XmlNumber(hi.y())
    << "</yMaximum><zMinimum type=\"Float\">" << XmlNumber(lo.z())
    << "</zMinimum><zMaximum type=\"Float\">" << XmlNumber(hi.z())
    << "</zMaximum></cartesianBounds>\n";
  if (intensity) {
    x << "      <intensityLimits type=\"Structure\"><intensityMinimum type=\"Float\">"
      << XmlNumber(unit ? 0.0 : imin) << "</intensityMinimum><intensityMaximum type=\"Float\">"
      << XmlNumber(unit ? 1.0 : imax) << "</intensityMaximum></intensityLimits>\n";
  }
  if (colour) {
    x << "      <colorLimits type=\"Structure\"><colorRedMinimum type=\"Integer\">0"
         "</colorRedMinimum><colorRedMaximum type=\"Integer\">255</colorRedMaximum>"
         "<colorGreenMinimum type=\"Integer\">0</colorGreenMinimum><colorGreenMaximum "
         "type=\"Integer\">255</colorGreenMaximum><colorBlueMinimum type=\"Integer\">0"
         "</colorBlueMinimum><colorBlueMaximum type=\"Integer\">255</colorBlueMaximum>"
         "</colorLimits>\n";
  }
  x << "      <points type=\"CompressedVector\" fileOffset=\""
    << PagedFile::ToPhysical(section_logical) << "\" recordCount=\"" << records
    << "\">\n        <prototype type=\"Structure\">\n";
  for (const char* axis : {"X", "Y", "Z"}) {
    x << "          <cartesian" << axis << " type=\"Float\" precision=\"single\"/>\n";
  }
  if (intensity) {
    x << "          <intensity type=\"Float\" precision=\"single\"/>\n"
         "          <isIntensityInvalid type=\"Integer\" minimum=\"0\" maximum=\"1\"/>\n";
  }
  if (colour) {
    for (const char* c : {"Red", "Green", "Blue"})
      x << "          <color" << c << " type=\"Integer\" minimum=\"0\" maximum=\"255\"/>\n";
    x << "          <isColorInvalid type=\"Integer\" minimum=\"0\" maximum=\"1\"/>\n";
  }
  x << "          <rowIndex type=\"Integer\" minimum=\"0\" maximum=\"" << scan.rows - 1
    << "\"/>\n          <columnIndex type=\"Integer\" minimum=\"0\" maximum=\"" << scan.cols - 1
    << "\"/>\n        </prototype>\n"
       "        <codecs type=\"Vector\" allowHeterogeneousChildren=\"1\"/>\n"
       "      </points>\n    </vectorChild>\n  </data3D>\n"
       "  <images2D type=\"Vector\" allowHeterogeneousChildren=\"1\">\n";
  for (std::size_t i = 0; images && i < images->size(); ++i) {
    const E57ImageInfo& m = (*images)[i].info;
    const E57Pose& pose = m.pose;
    x << "    <vectorChild type=\"Structure\">\n      <guid "
         "type=\"String\"><![CDATA[{scancam-image-"
      << i << "}]]></guid>\n      <name type=\"String\"><![CDATA[" << m.name
      << "]]></name>\n      <associatedData3DGuid type=\"String\"><![CDATA[{scancam-scan-"
      << records << "-" << scan.rows << "x" << scan.cols << "}]]></associatedData3DGuid>\n"
      << "      <pose type=\"Structure\"><rotation type=\"Structure\"><w type=\"Float\">"
      << XmlNumber(pose.rotation.w()) << "</w><x type=\"Float\">" << XmlNumber(pose.rotation.x())
      << "</x><y type=\"Float\">" << XmlNumber(pose.rotation.y()) << "</y><z type=\"Float\">"
      << XmlNumber(pose.rotation.z())
      << "</z></rotation><translation type=\"Structure\"><x type=\"Float\">"
      << XmlNumber(pose.translation.x()) << "</x><y type=\"Float\">"
      << XmlNumber(pose.translation.y()) << "</y><z type=\"Float\">"
      << XmlNumber(pose.translation.z()) << "</z></translation></pose>\n      <" << m.representation
      << "Representation type=\"Structure\">\n        <" << m.blob_type
      << "Image type=\"Blob\" fileOffset=\"" << PagedFile::ToPhysical(blob_logical[i])
      << "\" length=\"" << (*images)[i].bytes.size()
      << "\"/>\n        <imageWidth type=\"Integer\">" << m.width_px
      << "</imageWidth><imageHeight type=\"Integer\">" << m.height_px
      << "</imageHeight>\n        <pixelWidth type=\"Float\">" << XmlNumber(m.pixel_width_m)
      << "</pixelWidth><pixelHeight type=\"Float\">" << XmlNumber(m.pixel_height_m)
      << "</pixelHeight>\n";
    if (m.representation == "pinhole") {
      x << "        <focalLength type=\"Float\">" << XmlNumber(m.focal_length_m)
        << "</focalLength><principalPointX type=\"Float\">" << XmlNumber(m.principal_x_px)
        << "</principalPointX><principalPointY type=\"Float\">" << XmlNumber(m.principal_y_px)
        << "</principalPointY>\n";
    }
    x << "      </" << m.representation << "Representation>\n";
    if (m.representation == "pinhole" && m.has_leica_distortion) {  // Leica's extension
      const E57LeicaDistortion& d = m.leica;
      auto f = [&](const std::string& name, double v) {
        x << "        <dist:" << name << " type=\"Float\">" << XmlNumber(v) << "</dist:" << name
          << ">\n";
      };
      x << "      <dist:distortion type=\"Structure\">\n        <dist:CameraNumber "
           "type=\"Integer\">"
        << d.camera_number << "</dist:CameraNumber>\n        <dist:Type type=\"String\"><![CDATA["
        << d.type << "]]></dist:Type>\n";
      for (int k = 0; k < 6; ++k) f("CV_K" + std::to_string(k + 1), d.k[k]);
      f("CV_P1", d.p[0]);
      f("CV_P2", d.p[1]);
      f("CV_CX", d.cx_px);
      f("CV_CY", d.cy_px);
      f("CV_FX", d.fx_px);
      f("CV_FY", d.fy_px);
      x << "        <dist:CV_HEIGHT type=\"Integer\">" << d.height_px
        << "</dist:CV_HEIGHT>\n        <dist:CV_WIDTH type=\"Integer\">" << d.width_px
        << "</dist:CV_WIDTH>\n      </dist:distortion>\n";
    }
    x << "    </vectorChild>\n";
  }
  x << "  </images2D>\n</e57Root>\n";
  const std::string xml = x.str();
  const std::uint64_t total_logical = xml_logical + xml.size();
  const std::uint64_t pages = (total_logical + kPageData - 1) / kPageData;

  AtomicFile file(path);
  std::FILE* f = std::fopen(file.tmp().c_str(), "wb");
  if (!f) throw FileError(path, "", "cannot open the file for writing");
  try {
    PageWriter w(f, path);
    std::vector<std::uint8_t> head;
    head.insert(head.end(), {'A', 'S', 'T', 'M', '-', 'E', '5', '7'});
    PutLe(head, 1, 4);
    PutLe(head, 0, 4);
    PutLe(head, pages * kPage, 8);
    PutLe(head, PagedFile::ToPhysical(xml_logical), 8);
    PutLe(head, xml.size(), 8);
    PutLe(head, kPage, 8);
    PutLe(head, 1, 1);  // the compressed-vector section header
    head.insert(head.end(), 7, 0);
    PutLe(head, section_length, 8);
    PutLe(head, PagedFile::ToPhysical(section_logical + 32), 8);
    PutLe(head, 0, 8);  // no index packet
    w.Write(head.data(), head.size());
    std::vector<std::vector<std::uint8_t>> chunks(static_cast<std::size_t>(streams));
    std::vector<BitPacker> packers(static_cast<std::size_t>(streams));
    std::vector<std::uint8_t> packet;
    std::size_t next_cell = 0;  // the grid index of the next record
    for (std::size_t done = 0; done < records; done += kPerPacket) {
      const std::size_t n = std::min(kPerPacket, records - done);
      for (auto& c : chunks) c.clear();
      for (auto& p : packers) p.bytes.clear();
      for (std::size_t i = done; i < done + n; ++i) {
        while (!scan.valid(next_cell)) ++next_cell;
        const std::size_t k = next_cell++;
        const Eigen::Vector3f& p = scan.point_m[k];
        int s = 0;
        for (int a = 0; a < 3; ++a, ++s) {
          const std::uint8_t* b = reinterpret_cast<const std::uint8_t*>(&p[a]);
          chunks[s].insert(chunks[s].end(), b, b + 4);
        }
        if (intensity) {
          const float v = scan.intensity[k];
          const float written = std::isfinite(v) ? v : 0.f;
          const std::uint8_t* b = reinterpret_cast<const std::uint8_t*>(&written);
          chunks[s].insert(chunks[s].end(), b, b + 4);
          packers[s + 1].Put(std::isfinite(v) ? 0 : 1, 1);
          s += 2;
        }
        if (colour) {
          const bool has = !coloured || (*coloured)[k] != 0;
          for (int c = 0; c < 3; ++c) packers[s + c].Put(has ? (*rgb)[k][c] : 0, 8);
          packers[s + 3].Put(has ? 0 : 1, 1);
          s += 4;
        }
        packers[s].Put(k / static_cast<std::size_t>(scan.cols), row_bits);
        packers[s + 1].Put(k % static_cast<std::size_t>(scan.cols), col_bits);
      }
      if (done + n == records) {
        for (auto& p : packers) p.Finish();
      }
      packet.clear();
      PutLe(packet, 1, 1);
      PutLe(packet, 0, 1);
      PutLe(packet, 0, 2);  // length - 1, below
      PutLe(packet, static_cast<std::uint64_t>(streams), 2);
      for (int s = 0; s < streams; ++s) {
        const auto& c = chunks[s].empty() ? packers[s].bytes : chunks[s];
        PutLe(packet, c.size(), 2);
      }
      for (int s = 0; s < streams; ++s) {
        const auto& c = chunks[s].empty() ? packers[s].bytes : chunks[s];
        packet.insert(packet.end(), c.begin(), c.end());
      }
      while (packet.size() % 4) packet.push_back(0);
      if (packet.size() != packet_bytes(n) || packet.size() > 65536)
        throw Error("E57 writer: packet size mismatch (a bug)");
      packet[2] = static_cast<std::uint8_t>((packet.size() - 1) & 0xff);
      packet[3] = static_cast<std::uint8_t>((packet.size() - 1) >> 8);
      w.Write(packet.data(), packet.size());
      if ((done / kPerPacket) % 64 == 0) progress(double(done) / double(records), "writing E57");
    }
    for (std::size_t i = 0; images && i < images->size(); ++i) {
      const std::vector<std::uint8_t>& bytes = (*images)[i].bytes;
      if (w.logical() != blob_logical[i]) throw Error("E57 writer: blob offset mismatch (a bug)");
      std::vector<std::uint8_t> bh;
      PutLe(bh, 0, 8);  // section id 0 (blob) and 7 reserved bytes
      PutLe(bh, (16 + bytes.size() + 3) / 4 * 4, 8);
      w.Write(bh.data(), bh.size());
      w.Write(bytes.data(), bytes.size());
      const std::uint8_t zeros[4] = {0, 0, 0, 0};
      w.Write(zeros, (4 - (16 + bytes.size()) % 4) % 4);
    }
    if (w.logical() != xml_logical) throw Error("E57 writer: section size mismatch (a bug)");
    w.WriteString(xml);
    w.Pad();
  } catch (...) {
    std::fclose(f);
    throw;
  }
  if (std::fclose(f) != 0) throw FileError(path, "", "write error");
  file.Commit();
  progress(1.0, "writing E57");
}

}  // namespace scancam::io
