// Float TIFF and 8-bit views: see scancam/image_io.h.
#include "scancam/image_io.h"

#include <jerror.h>
#include <jpeglib.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <csetjmp>
#include <cstdint>
#include <cstdio>  // before jpeglib.h, which uses FILE
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

void CheckFloat1(const cv::Mat& image, const std::string& what) {
  if (image.type() != CV_32FC1)
    throw Error(what + ": expected a one-channel 32-bit float image (CV_32FC1), got type " +
                std::to_string(image.type()));
}

void CheckPercentile(double p) {
  if (!(p >= 0.0 && p <= 100.0))
    throw Error("percentile " + std::to_string(p) + " is not in [0, 100]");
}

// A float's bits as an unsigned key that sorts as the float does (negative values' bits
// inverted, positive values' sign bit set); -0 and +0 share +0's key, as they compare equal.
inline std::uint32_t SortKey(float v) {
  std::uint32_t b;
  std::memcpy(&b, &v, sizeof b);
  if (b == 0x80000000u) b = 0u;
  return (b & 0x80000000u) ? ~b : (b | 0x80000000u);
}

// Nearest-rank percentiles of the finite values (the value at rank round(p / 100 * (n - 1))
// of the sorted finite values), exactly, without copying the data: a count of the values'
// sortable keys by their top 12 bits (sign, exponent, 3 mantissa bits), then the values of
// the bins holding the wanted ranks gathered and selected with nth_element. Rows in parallel.
std::vector<float> Percentiles(const cv::Mat& image, const std::vector<double>& ps) {
  for (double p : ps) CheckPercentile(p);
  std::vector<float> out(ps.size(), kNaN);
  if (image.empty()) return out;
  constexpr int kShift = 20;
  constexpr std::size_t kBins = std::size_t(1) << (32 - kShift);
  std::vector<std::uint64_t> hist(kBins, 0);
#pragma omp parallel
  {
    std::vector<std::uint64_t> h(kBins, 0);
#pragma omp for schedule(static)
    for (int r = 0; r < image.rows; ++r) {
      const float* p = image.ptr<float>(r);
      for (int c = 0; c < image.cols; ++c)
        if (std::isfinite(p[c])) ++h[SortKey(p[c]) >> kShift];
    }
#pragma omp critical
    for (std::size_t i = 0; i < kBins; ++i) hist[i] += h[i];
  }
  std::uint64_t count = 0;
  for (std::uint64_t c : hist) count += c;
  if (count == 0) return out;
  // Per percentile: its bin and its rank among that bin's values.
  std::vector<std::pair<std::uint32_t, std::uint64_t>> where;
  std::vector<std::uint32_t> bins;  // distinct bins to gather
  for (double p : ps) {
    std::uint64_t rank = static_cast<std::uint64_t>(std::llround(p / 100.0 * double(count - 1)));
    std::uint32_t bin = 0;
    while (rank >= hist[bin]) rank -= hist[bin++];  // ends: rank < count
    where.emplace_back(bin, rank);
    if (std::find(bins.begin(), bins.end(), bin) == bins.end()) bins.push_back(bin);
  }
  for (const std::uint32_t bin : bins) {
    std::vector<float> values;
    values.reserve(hist[bin]);
#pragma omp parallel
    {
      std::vector<float> mine;
#pragma omp for schedule(static) nowait
      for (int r = 0; r < image.rows; ++r) {
        const float* p = image.ptr<float>(r);
        for (int c = 0; c < image.cols; ++c)
          if (std::isfinite(p[c]) && (SortKey(p[c]) >> kShift) == bin) mine.push_back(p[c]);
      }
#pragma omp critical
      values.insert(values.end(), mine.begin(), mine.end());
    }
    for (std::size_t j = 0; j < ps.size(); ++j) {
      if (where[j].first != bin) continue;
      const auto k = static_cast<std::ptrdiff_t>(where[j].second);
      std::nth_element(values.begin(), values.begin() + k, values.end());
      out[j] = values[static_cast<std::size_t>(k)];
    }
  }
  return out;
}

// ---- image headers ----------------------------------------------------------------------------

// Random access to a file's bytes for the header readers; reads past the end fail.
class ByteFile {
 public:
  explicit ByteFile(const std::string& path) : path_(path), in_(path, std::ios::binary) {
    if (!in_) throw FileError(path, "", "cannot open the file for reading");
    in_.seekg(0, std::ios::end);
    size_ = static_cast<std::uint64_t>(std::max<std::streamoff>(0, in_.tellg()));
  }
  std::uint64_t size() const { return size_; }
  // n bytes at `offset` into buf; false when the file is shorter.
  bool Read(std::uint64_t offset, void* buf, std::size_t n) {
    if (offset > size_ || n > size_ - offset) return false;
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(offset));
    return static_cast<bool>(in_.read(static_cast<char*>(buf), static_cast<std::streamsize>(n)));
  }
  [[noreturn]] void Fail(std::uint64_t offset, const std::string& what) const {
    throw FileError(path_, "byte " + std::to_string(offset), what);
  }

 private:
  std::string path_;
  std::ifstream in_;
  std::uint64_t size_ = 0;
};

std::uint32_t Be32(const unsigned char* b) {
  return std::uint32_t(b[0]) << 24 | std::uint32_t(b[1]) << 16 | std::uint32_t(b[2]) << 8 | b[3];
}
std::uint16_t Be16(const unsigned char* b) { return std::uint16_t(b[0] << 8 | b[1]); }

// CRC-32 (ISO-HDLC, as PNG uses), table-driven.
std::uint32_t Crc32Update(std::uint32_t crc, const unsigned char* p, std::size_t n) {
  static const std::array<std::uint32_t, 256> kTable = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  for (std::size_t i = 0; i < n; ++i) crc = kTable[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return crc;
}

const unsigned char kPngSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};

std::string ChunkName(const unsigned char* t) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const bool letter = (t[i] >= 'A' && t[i] <= 'Z') || (t[i] >= 'a' && t[i] <= 'z');
    s += letter ? std::string(1, static_cast<char>(t[i])) : "?";
  }
  return s;
}

ImageFileInfo PngHeader(ByteFile& f) {
  unsigned char b[24];
  if (!f.Read(0, b, 24)) f.Fail(f.size(), "PNG file ends inside its header (truncated)");
  if (Be32(b + 8) != 13 || std::string(reinterpret_cast<char*>(b + 12), 4) != "IHDR") {
    f.Fail(8, "damaged PNG: the first chunk is not a 13-byte IHDR");
  }
  const std::uint32_t w = Be32(b + 16), h = Be32(b + 20);
  if (w == 0 || h == 0 || w > 0x7FFFFFFFu || h > 0x7FFFFFFFu) {
    f.Fail(16, "damaged PNG header: image size " + std::to_string(w) + "x" + std::to_string(h));
  }
  return {"PNG", static_cast<int>(std::min<std::uint32_t>(w, 0x7FFFFFFF)),
          static_cast<int>(std::min<std::uint32_t>(h, 0x7FFFFFFF))};
}

// Walks every chunk of a PNG, checking lengths and CRCs, up to IEND (libpng would print its own
// text, e.g. "IDAT: CRC error", for these; we name the byte and the chunk instead).
void CheckPngChunks(ByteFile& f) {
  std::uint64_t pos = 8;
  std::vector<unsigned char> buf(1 << 16);
  while (true) {
    unsigned char head[8];
    if (!f.Read(pos, head, 8)) {
      f.Fail(pos, "PNG file ends before its IEND chunk (truncated)");
    }
    const std::uint32_t len = Be32(head);
    const std::string name = ChunkName(head + 4);
    if (len > 0x7FFFFFFFu || name.find('?') != std::string::npos) {
      f.Fail(pos, "damaged PNG: no valid chunk starts here (bytes inserted, removed or changed)");
    }
    if (pos + 12 + len > f.size()) {
      f.Fail(pos, "PNG chunk '" + name + "' runs past the end of the file (truncated)");
    }
    std::uint32_t crc = Crc32Update(0xFFFFFFFFu, head + 4, 4);
    for (std::uint64_t done = 0; done < len;) {
      const std::size_t n =
          static_cast<std::size_t>(std::min<std::uint64_t>(buf.size(), len - done));
      if (!f.Read(pos + 8 + done, buf.data(), n)) f.Fail(pos, "read error");
      crc = Crc32Update(crc, buf.data(), n);
      done += n;
    }
    unsigned char stored[4];
    if (!f.Read(pos + 8 + len, stored, 4)) f.Fail(pos, "read error");
    if ((crc ^ 0xFFFFFFFFu) != Be32(stored)) {
      f.Fail(pos, "PNG chunk '" + name + "' is damaged (CRC mismatch: bytes changed)");
    }
    pos += 12 + std::uint64_t(len);
    if (name == "IEND") return;
  }
}

// Walks a JPEG's segments from SOI to the first SOS: the size from the frame header (SOFn),
// and in `scan_start` the byte after the SOS header, where the compressed data begin.
ImageFileInfo JpegHeader(ByteFile& f, std::uint64_t* scan_start = nullptr) {
  ImageFileInfo info;
  std::uint64_t pos = 2;
  while (true) {
    unsigned char m[2];
    if (!f.Read(pos, m, 2)) f.Fail(pos, "JPEG file ends before its image data (truncated)");
    if (m[0] != 0xFF) f.Fail(pos, "damaged JPEG: expected a marker (0xFF), found another byte");
    if (m[1] == 0xFF) {  // fill byte
      ++pos;
      continue;
    }
    const unsigned char t = m[1];
    pos += 2;
    if (t == 0x01 || (t >= 0xD0 && t <= 0xD8)) continue;  // markers without a length
    if (t == 0xD9) f.Fail(pos - 2, "damaged JPEG: end marker before the image data");
    unsigned char l[2];
    if (!f.Read(pos, l, 2)) f.Fail(pos, "JPEG file ends inside a segment (truncated)");
    const std::uint16_t len = Be16(l);
    if (len < 2) f.Fail(pos, "damaged JPEG: segment length " + std::to_string(len));
    if (t == 0xDA) {
      if (info.format.empty())
        f.Fail(pos - 2, "damaged JPEG: no frame header (SOF) before the image data");
      if (scan_start) *scan_start = pos + len;
      return info;
    }
    const bool sof = t >= 0xC0 && t <= 0xCF && t != 0xC4 && t != 0xC8 && t != 0xCC;
    if (sof && info.format.empty()) {
      unsigned char b[5];
      if (len < 7 || !f.Read(pos + 2, b, 5)) f.Fail(pos, "damaged JPEG frame header");
      const int h = Be16(b + 1), w = Be16(b + 3);
      if (w == 0 || h == 0) {
        f.Fail(pos, "JPEG frame header gives an image size of " + std::to_string(w) + "x" +
                        std::to_string(h) + " px");
      }
      info = {"JPEG", w, h};
    }
    pos += len;
  }
}

// A JPEG must end with its EOI marker after the compressed data: libjpeg decodes a truncated
// file anyway (grey lower part, "Premature end of JPEG file" on stderr). Looks for FF D9 after
// the data start, searching from the end (some cameras append trailers after EOI).
void CheckJpegEnd(ByteFile& f) {
  std::uint64_t pos = 0;
  JpegHeader(f, &pos);
  std::vector<unsigned char> buf(1 << 16);
  std::uint64_t end = f.size();
  while (end > pos) {
    const std::uint64_t begin = end - std::min<std::uint64_t>(end - pos, buf.size());
    const std::size_t n = static_cast<std::size_t>(end - begin);
    if (!f.Read(begin, buf.data(), n)) f.Fail(begin, "read error");
    for (std::size_t i = n; i-- > 1;) {
      if (buf[i - 1] == 0xFF && buf[i] == 0xD9) return;
    }
    if (begin == pos) break;
    end = begin + 1;  // keep one byte of overlap for a marker split between blocks
  }
  f.Fail(f.size(), "JPEG file ends before its end marker (truncated)");
}

// What libjpeg said while decoding the entropy-coded data: the first warning (a code from
// jerror.h, libjpeg's text for it, the byte offset where it was noticed) or a fatal error.
struct JpegDecodeReport {
  bool fatal = false;
  int warning_code = -1;  // -1: no warning
  long offset = -1;
  char text[JMSG_LENGTH_MAX] = {0};
  bool decoded = false;  // DecodeJpeg filled the image
};

struct JpegErrorManager {
  jpeg_error_mgr base;
  std::jmp_buf jump;
  JpegDecodeReport* report;
  FILE* file;
  j_decompress_ptr info;
};

long JpegOffset(JpegErrorManager* m) {
  const long at = std::ftell(m->file);
  if (at < 0 || m->info->src == nullptr) return at;
  return at - static_cast<long>(m->info->src->bytes_in_buffer);
}

void JpegOnError(j_common_ptr c) {
  auto* m = reinterpret_cast<JpegErrorManager*>(c->err);
  m->report->fatal = true;
  m->report->offset = JpegOffset(m);
  (*c->err->format_message)(c, m->report->text);
  std::longjmp(m->jump, 1);
}

void JpegOnMessage(j_common_ptr c, int level) {
  // level -1: a warning about the data (damaged entropy data, a premature end); level >= 0:
  // trace messages, ignored. libjpeg's own handler would print to stderr.
  auto* m = reinterpret_cast<JpegErrorManager*>(c->err);
  if (level != -1 || m->report->warning_code >= 0) return;
  m->report->warning_code = c->err->msg_code;
  m->report->offset = JpegOffset(m);
  (*c->err->format_message)(c, m->report->text);
}

// True when cv::imread (OpenCV 4.6, not IMREAD_UNCHANGED) leaves a JPEG as decoded: it turns
// the image by the orientation tag (0x0112) of IFD0 in the first APP1 marker, read as EXIF
// from its byte 6 on. Only the plain cases answer true: no APP1 marker, or an "Exif" APP1
// whose IFD0 is readable and has no orientation tag or orientation 1 (its first one, as
// OpenCV's map keeps). Anything else answers false and the caller lets cv::imread decode.
bool ExifKeepsOrientation(const jpeg_decompress_struct& info) {
  jpeg_saved_marker_ptr m = info.marker_list;
  while (m != nullptr && m->marker != JPEG_APP0 + 1) m = m->next;
  if (m == nullptr) return true;
  const unsigned char* d = m->data;
  const std::size_t n = m->data_length;
  if (n < 6 + 8 || std::memcmp(d, "Exif\0\0", 6) != 0) return false;
  const unsigned char* t = d + 6;
  const std::size_t tn = n - 6;
  const bool little = t[0] == 'I' && t[1] == 'I';
  if (!little && !(t[0] == 'M' && t[1] == 'M')) return false;
  auto u16 = [&](std::size_t at) {
    return little ? t[at] | (t[at + 1] << 8) : (t[at] << 8) | t[at + 1];
  };
  auto u32 = [&](std::size_t at) {
    return little ? std::uint32_t(u16(at)) | (std::uint32_t(u16(at + 2)) << 16)
                  : (std::uint32_t(u16(at)) << 16) | std::uint32_t(u16(at + 2));
  };
  if (u16(2) != 42) return false;
  const std::uint32_t ifd = u32(4);
  if (ifd > tn || tn - ifd < 2) return false;
  const std::size_t count = u16(ifd);
  if ((tn - ifd - 2) / 12 < count) return false;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t e = ifd + 2 + 12 * k;
    if (u16(e) == 0x0112) return u16(e + 8) == 1;
  }
  return true;
}

// The cv::Mat type cv::imread(flags) gives this JPEG when ReadJpeg may decode it itself with
// the same result (libjpeg-turbo, the library OpenCV decodes with, with OpenCV's settings: the
// default DCT and upsampling, BGR or grey output, no scaling, no EXIF turn); -1 otherwise
// (CMYK/YCCK, 12-bit, Motion-JPEG without Huffman tables, other flags, an EXIF orientation).
int OwnJpegDecodeType(const jpeg_decompress_struct& info, int flags) {
  if (info.num_components != 1 && info.num_components != 3) return -1;
  if (info.jpeg_color_space != JCS_GRAYSCALE && info.jpeg_color_space != JCS_YCbCr &&
      info.jpeg_color_space != JCS_RGB)
    return -1;
  if (info.data_precision != 8) return -1;
  if (info.ac_huff_tbl_ptrs[0] == nullptr && info.ac_huff_tbl_ptrs[1] == nullptr &&
      info.dc_huff_tbl_ptrs[0] == nullptr && info.dc_huff_tbl_ptrs[1] == nullptr)
    return -1;  // OpenCV loads its own tables for these
  if (flags == cv::IMREAD_UNCHANGED) return info.num_components > 1 ? CV_8UC3 : CV_8UC1;
  if (flags != cv::IMREAD_COLOR && flags != cv::IMREAD_GRAYSCALE) return -1;
  if (!ExifKeepsOrientation(info)) return -1;
  return flags == cv::IMREAD_COLOR ? CV_8UC3 : CV_8UC1;
}

// Decodes a JPEG with libjpeg, hearing every warning about its entropy-coded data. When
// OwnJpegDecodeType says so, at full size into *image (report.decoded), exactly as
// cv::imread(flags) would; otherwise at 1/8 scale (every Huffman code is still read, the
// inverse DCT mostly skipped) only to hear libjpeg, and the caller decodes with cv::imread.
// C only between setjmp and longjmp (nothing here owns a destructor; *image is the caller's).
JpegDecodeReport DecodeJpeg(FILE* file, int flags, cv::Mat* image) {
  JpegDecodeReport report;
  jpeg_decompress_struct info;
  JpegErrorManager err;
  info.err = jpeg_std_error(&err.base);
  err.base.error_exit = JpegOnError;
  err.base.emit_message = JpegOnMessage;
  err.report = &report;
  err.file = file;
  err.info = &info;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&info);
    report.decoded = false;
    return report;
  }
  jpeg_create_decompress(&info);
  jpeg_stdio_src(&info, file);
  jpeg_save_markers(&info, JPEG_APP0 + 1, 0xFFFF);
  jpeg_read_header(&info, TRUE);
  const int type = OwnJpegDecodeType(info, flags);
  if (type >= 0) {
    info.out_color_space = CV_MAT_CN(type) == 3 ? JCS_EXT_BGR : JCS_GRAYSCALE;
    jpeg_start_decompress(&info);
    bool allocated = false;
    try {
      image->create(static_cast<int>(info.output_height), static_cast<int>(info.output_width),
                    type);
      allocated = true;
    } catch (...) {
    }
    if (!allocated) {
      jpeg_destroy_decompress(&info);
      throw std::bad_alloc();
    }
    while (info.output_scanline < info.output_height) {
      JSAMPROW row = image->ptr(static_cast<int>(info.output_scanline));
      jpeg_read_scanlines(&info, &row, 1);
    }
  } else {
    info.scale_num = 1;
    info.scale_denom = 8;
    info.dct_method = JDCT_IFAST;
    info.do_fancy_upsampling = FALSE;
    jpeg_start_decompress(&info);
    JSAMPARRAY row = (*info.mem->alloc_sarray)(reinterpret_cast<j_common_ptr>(&info), JPOOL_IMAGE,
                                               info.output_width * info.output_components, 1);
    while (info.output_scanline < info.output_height) jpeg_read_scanlines(&info, row, 1);
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  report.decoded = type >= 0;
  return report;
}

// A JPEG whose image data is damaged decodes "successfully" into grey or shifted blocks, with
// libjpeg's "Corrupt JPEG data: ..." printed to stderr. Such a photo would paint wrong colours:
// refuse it in plain words. Extra bytes between segments (JWRN_EXTRANEOUS_DATA, written by some
// cameras) leave the pixels intact and pass. Returns true when it decoded the image into
// *image (one pass: DecodeJpeg), false when cv::imread still has to.
bool ReadJpeg(const std::string& path, int flags, cv::Mat* image) {
  FILE* file = std::fopen(path.c_str(), "rb");
  if (file == nullptr) throw FileError(path, "", "cannot open the JPEG file");
  struct Close {
    FILE* f;
    ~Close() { std::fclose(f); }
  } close{file};
  const JpegDecodeReport r = DecodeJpeg(file, flags, image);
  const std::string place = r.offset >= 0 ? "byte " + std::to_string(r.offset) : std::string();
  const std::string said = std::string(" (libjpeg: \"") + r.text + "\")";
  if (r.fatal) throw FileError(path, place, "damaged JPEG: cannot be decoded" + said);
  if (r.warning_code < 0 || r.warning_code == JWRN_EXTRANEOUS_DATA) return r.decoded;
  std::string what = "the JPEG's image data is damaged";
  if (r.warning_code == JWRN_JPEG_EOF) what = "the JPEG's image data ends early (truncated)";
  throw FileError(path, place,
                  what + said +
                      ": part of the photo would decode as grey or shifted blocks; copy or export "
                      "the photo again");
}

ImageFileInfo TiffHeader(ByteFile& f, bool little) {
  auto u = [&](const unsigned char* b, int n) {
    std::uint64_t v = 0;
    for (int i = 0; i < n; ++i) v |= std::uint64_t(b[little ? i : n - 1 - i]) << (8 * i);
    return v;
  };
  unsigned char h[16];
  if (!f.Read(0, h, 8)) f.Fail(0, "TIFF file ends inside its header (truncated)");
  const bool big = u(h + 2, 2) == 43;
  std::uint64_t ifd;
  if (big) {
    if (!f.Read(0, h, 16)) f.Fail(0, "TIFF file ends inside its header (truncated)");
    ifd = u(h + 8, 8);
  } else {
    ifd = u(h + 4, 4);
  }
  const int count_size = big ? 8 : 2, entry_size = big ? 20 : 12, value_size = big ? 8 : 4;
  unsigned char c[8];
  if (!f.Read(ifd, c, count_size)) f.Fail(ifd, "damaged TIFF: the first IFD lies outside the file");
  const std::uint64_t n = u(c, count_size);
  if (n == 0 || n > 4096) f.Fail(ifd, "damaged TIFF: IFD with " + std::to_string(n) + " entries");
  std::uint64_t w = 0, hgt = 0;
  std::vector<unsigned char> e(static_cast<std::size_t>(n) * entry_size);
  if (!f.Read(ifd + count_size, e.data(), e.size())) f.Fail(ifd, "damaged TIFF: IFD cut short");
  for (std::uint64_t k = 0; k < n; ++k) {
    const unsigned char* p = e.data() + k * entry_size;
    const std::uint64_t tag = u(p, 2), type = u(p + 2, 2);
    const unsigned char* val = p + 4 + value_size;
    std::uint64_t v = 0;
    if (type == 3)
      v = u(val, 2);  // SHORT
    else if (type == 4)
      v = u(val, 4);  // LONG
    else if (type == 16 && big)
      v = u(val, 8);  // LONG8
    else if (tag == 256 || tag == 257)
      f.Fail(ifd, "damaged TIFF: image size of an unknown type");
    if (tag == 256) w = v;
    if (tag == 257) hgt = v;
  }
  if (w == 0 || hgt == 0) f.Fail(ifd, "damaged TIFF: no image width / length in the first IFD");
  return {"TIFF", static_cast<int>(std::min<std::uint64_t>(w, 0x7FFFFFFF)),
          static_cast<int>(std::min<std::uint64_t>(hgt, 0x7FFFFFFF))};
}

ImageFileInfo BmpHeader(ByteFile& f) {
  unsigned char b[26];
  if (!f.Read(0, b, 26)) f.Fail(0, "BMP file ends inside its header (truncated)");
  auto le = [&](int o, int n) {
    std::uint32_t v = 0;
    for (int i = 0; i < n; ++i) v |= std::uint32_t(b[o + i]) << (8 * i);
    return v;
  };
  long long w, h;
  if (le(14, 4) == 12) {
    w = le(18, 2), h = le(20, 2);
  } else {
    w = static_cast<std::int32_t>(le(18, 4)), h = static_cast<std::int32_t>(le(22, 4));
  }
  w = std::llabs(w), h = std::llabs(h);
  if (w == 0 || h == 0)
    f.Fail(18, "damaged BMP header: image size " + std::to_string(w) + "x" + std::to_string(h));
  return {"BMP", static_cast<int>(std::min<long long>(w, 0x7FFFFFFF)),
          static_cast<int>(std::min<long long>(h, 0x7FFFFFFF))};
}

ImageFileInfo PnmHeader(ByteFile& f) {
  unsigned char b[512];
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(sizeof b, f.size()));
  f.Read(0, b, n);
  std::size_t i = 2;
  long long v[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    while (i < n && (std::isspace(b[i]) || b[i] == '#')) {
      if (b[i] == '#') {
        while (i < n && b[i] != '\n') ++i;
      } else {
        ++i;
      }
    }
    if (i >= n || !std::isdigit(b[i])) f.Fail(i, "damaged PNM header: expected the image size");
    while (i < n && std::isdigit(b[i]) && v[k] < 1000000000) v[k] = v[k] * 10 + (b[i++] - '0');
  }
  if (v[0] == 0 || v[1] == 0) f.Fail(2, "damaged PNM header: image size 0");
  return {"PNM", static_cast<int>(v[0]), static_cast<int>(v[1])};
}

ImageFileInfo WebpHeader(ByteFile& f) {
  unsigned char b[30];
  if (!f.Read(0, b, 30)) f.Fail(f.size(), "WebP file ends inside its header (truncated)");
  const std::string chunk(reinterpret_cast<char*>(b + 12), 4);
  auto le = [&](int o, int n) {
    std::uint32_t v = 0;
    for (int i = 0; i < n; ++i) v |= std::uint32_t(b[o + i]) << (8 * i);
    return v;
  };
  if (chunk == "VP8 ") {  // lossy: key frame start code, then 14-bit width and height
    if (b[23] != 0x9D || b[24] != 0x01 || b[25] != 0x2A) f.Fail(23, "damaged WebP (VP8) header");
    return {"WebP", static_cast<int>(le(26, 2) & 0x3FFF), static_cast<int>(le(28, 2) & 0x3FFF)};
  }
  if (chunk == "VP8L") {  // lossless: signature 0x2F, then 14-bit width - 1 and height - 1
    if (b[20] != 0x2F) f.Fail(20, "damaged WebP (VP8L) header");
    const std::uint32_t v = le(21, 4);
    return {"WebP", static_cast<int>((v & 0x3FFF) + 1), static_cast<int>(((v >> 14) & 0x3FFF) + 1)};
  }
  if (chunk == "VP8X") {  // extended: 24-bit canvas width - 1 and height - 1
    return {"WebP", static_cast<int>(le(24, 3) + 1), static_cast<int>(le(27, 3) + 1)};
  }
  f.Fail(12, "damaged WebP: unknown first chunk");
}

}  // namespace

ImageFileInfo ReadImageHeader(const std::string& path) {
  ByteFile f(path);
  unsigned char m[8] = {0};
  const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(8, f.size()));
  f.Read(0, m, n);
  if (n == 8 && std::equal(m, m + 8, kPngSignature)) return PngHeader(f);
  if (n >= 3 && m[0] == 0xFF && m[1] == 0xD8 && m[2] == 0xFF) return JpegHeader(f);
  if (n >= 4 && ((m[0] == 'I' && m[1] == 'I' && (m[2] == 42 || m[2] == 43) && m[3] == 0) ||
                 (m[0] == 'M' && m[1] == 'M' && m[2] == 0 && (m[3] == 42 || m[3] == 43)))) {
    return TiffHeader(f, m[0] == 'I');
  }
  if (n >= 2 && m[0] == 'B' && m[1] == 'M') return BmpHeader(f);
  if (n == 8 && std::equal(m, m + 4, "RIFF") && f.size() >= 16) {
    unsigned char w[4];
    if (f.Read(8, w, 4) && std::equal(w, w + 4, "WEBP")) return WebpHeader(f);
  }
  if (n >= 3 && m[0] == 'P' && m[1] >= '1' && m[1] <= '6' && std::isspace(m[2])) {
    return PnmHeader(f);
  }
  return {};
}

cv::Mat ReadImage(const std::string& path, int flags, const std::string& what,
                  const std::function<void(int, int)>& check_size) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw FileError(path, "", what + " not found (or not a regular file)");
  }
  auto check = [&](long long w, long long h, const char* when) {
    // The caller's size first: "not the camera's size" is the more useful message. Before
    // decoding, the header's size may still be turned by an EXIF orientation (cv::imread applies
    // it): the swapped size passes too, the decoded size is then checked exactly.
    if (check_size) {
      try {
        check_size(static_cast<int>(w), static_cast<int>(h));
      } catch (const Error&) {
        bool swapped_ok = false;
        if (std::string(when) != "(decoded)") {
          try {
            check_size(static_cast<int>(h), static_cast<int>(w));
            swapped_ok = true;
          } catch (const Error&) {
          }
        }
        if (!swapped_ok) throw;
      }
    }
    if (w > kMaxImageSidePx || h > kMaxImageSidePx || w * h > kMaxImagePixels) {
      throw FileError(path, "",
                      what + " is " + std::to_string(w) + "x" + std::to_string(h) + " px " + when +
                          ", beyond ScanCam's limit of " + std::to_string(kMaxImageSidePx) +
                          " px per side and " + std::to_string(kMaxImagePixels) + " px in all");
    }
  };
  // Only formats whose size is known before decoding: OpenCV's own limit (2^30 px) is fixed
  // when its library loads and would let a small file allocate gigabytes.
  const ImageFileInfo info = ReadImageHeader(path);
  if (info.format.empty()) {
    throw FileError(path, "",
                    "not a PNG, JPEG, TIFF, BMP, WebP or PNM " + what +
                        " (the formats whose size ScanCam checks before decoding)");
  }
  check(info.width, info.height, "(from its header, not decoded)");
  {
    ByteFile f(path);
    if (info.format == "PNG") CheckPngChunks(f);
    if (info.format == "JPEG") CheckJpegEnd(f);
  }
  cv::Mat image;
  try {
    // A JPEG is decoded once: libjpeg hears its damage while decoding it (ReadJpeg), and
    // cv::imread decodes only the cases that path leaves to it.
    const bool decoded = info.format == "JPEG" && ReadJpeg(path, flags, &image);
    if (!decoded) image = cv::imread(path, flags);
  } catch (const cv::Exception& e) {
    const std::string msg = e.what();
    if (msg.find("MAX_IMAGE_PIXELS") != std::string::npos) {  // OpenCV's limit, as a sentence
      throw FileError(path, "", what + " is larger than OpenCV's pixel limit (not decoded)");
    }
    throw FileError(path, "", "cannot decode the " + what + ": " + PlainErrorMessage(e));
  } catch (const std::bad_alloc&) {
    throw FileError(path, "", "not enough memory to decode the " + what);
  }
  if (image.empty()) {
    throw FileError(path, "", "cannot decode the " + what + " (damaged " + info.format + " data)");
  }
  check(image.cols, image.rows, "(decoded)");
  return image;
}

void WriteFloatTiff(const std::string& path, const cv::Mat& image) {
  if (image.type() != CV_32FC1 || image.empty())
    throw FileError(path, "", "not written: expected a non-empty CV_32FC1 image");
  bool ok = false;
  std::string why;
  try {
    // OpenCV writes CV_32F TIFFs as SAMPLEFORMAT_IEEEFP with lossless compression.
    WriteFileAtomically(path, [&](const std::string& tmp) {
      if (!cv::imwrite(tmp, image)) throw FileError(path, "", "cannot write the float TIFF");
    });
    ok = true;
  } catch (const cv::Exception& e) {
    why = e.what();
  }
  if (!ok)
    throw FileError(path, "", "cannot write the float TIFF" + (why.empty() ? "" : ": " + why));
}

cv::Mat ReadFloatTiff(const std::string& path) {
  const cv::Mat image = ReadImage(path, cv::IMREAD_UNCHANGED, "image");
  if (image.type() != CV_32FC1)
    throw FileError(path, "",
                    "expected a one-channel 32-bit float TIFF, found " +
                        std::to_string(image.channels()) + " channel(s) of depth code " +
                        std::to_string(image.depth()));
  return image;
}

float PercentileOfFinite(const cv::Mat& image, double percentile) {
  CheckPercentile(percentile);
  if (image.empty()) return kNaN;
  CheckFloat1(image, "PercentileOfFinite");
  return Percentiles(image, {percentile})[0];
}

cv::Vec2f ViewRange(const cv::Mat& image, const ViewOptions& options) {
  if (options.fixed_range)
    return {static_cast<float>(options.low), static_cast<float>(options.high)};
  if (image.empty()) return {kNaN, kNaN};
  CheckFloat1(image, "ViewRange");
  if (options.low_percentile > options.high_percentile)
    throw Error("view: low percentile " + std::to_string(options.low_percentile) +
                " is above high percentile " + std::to_string(options.high_percentile));
  const auto p = Percentiles(image, {options.low_percentile, options.high_percentile});
  return {p[0], p[1]};
}

cv::Mat MakeView(const cv::Mat& image, const ViewOptions& options) {
  if (image.empty()) return cv::Mat();
  CheckFloat1(image, "MakeView");
  if (!(options.gamma > 0.0 && options.gamma <= 10.0))
    throw Error("MakeView: gamma " + std::to_string(options.gamma) + " is not in (0, 10]");
  // Equalisation: the sorted finite values; a value's grey is its rank among them.
  std::vector<float> sorted;
  if (options.equalize) {
    sorted.reserve(image.total());
    for (int r = 0; r < image.rows; ++r) {
      const float* p = image.ptr<float>(r);
      for (int c = 0; c < image.cols; ++c)
        if (std::isfinite(p[c])) sorted.push_back(p[c]);
    }
    std::sort(sorted.begin(), sorted.end());
  }
  const auto equalized = [&](float v) {
    const std::size_t rank = static_cast<std::size_t>(
        std::upper_bound(sorted.begin(), sorted.end(), v) - sorted.begin());
    if (sorted.size() < 2) return uchar{128};
    return static_cast<uchar>(std::lround(255.0 * double(rank - 1) / double(sorted.size() - 1)));
  };
  const cv::Vec2f range = options.equalize ? cv::Vec2f(0.f, 1.f) : ViewRange(image, options);
  const float lo = range[0], hi = range[1];
  const bool flat = !(hi > lo);  // also true when there is no finite value
  const float scale = flat ? 0.f : 255.f / (hi - lo);

  const auto grey_of = [&](float v) -> uchar {
    if (options.equalize) return equalized(v);
    if (flat) return 128;
    float t = std::clamp((v - lo) * scale, 0.f, 255.f);
    if (options.gamma != 1.0) t = 255.f * static_cast<float>(std::pow(t / 255.0, options.gamma));
    return static_cast<uchar>(std::lround(t));
  };
  if (options.colormap != Colormap::kJet) {
    // Grey: the picture in one pass (rows in parallel).
    cv::Mat view(image.size(), options.alpha ? CV_8UC4 : CV_8UC3);
    const cv::Vec4b invalid_bgra(kInvalidViewBgr[0], kInvalidViewBgr[1], kInvalidViewBgr[2], 255);
#pragma omp parallel for schedule(static)
    for (int r = 0; r < image.rows; ++r) {
      const float* p = image.ptr<float>(r);
      auto* out3 = view.ptr<cv::Vec3b>(r);
      auto* out4 = view.ptr<cv::Vec4b>(r);
      for (int c = 0; c < image.cols; ++c) {
        const float v = p[c];
        const bool finite = std::isfinite(v);
        const uchar g = finite ? grey_of(v) : 0;
        if (options.alpha) {
          out4[c] = finite ? cv::Vec4b(g, g, g, 255) : invalid_bgra;
        } else {
          out3[c] = finite ? cv::Vec3b(g, g, g) : kInvalidViewBgr;
        }
      }
    }
    return view;
  }
  cv::Mat grey(image.size(), CV_8UC1);
  cv::Mat invalid(image.size(), CV_8UC1);
#pragma omp parallel for schedule(static)
  for (int r = 0; r < image.rows; ++r) {
    const float* p = image.ptr<float>(r);
    uchar* g = grey.ptr<uchar>(r);
    uchar* bad = invalid.ptr<uchar>(r);
    for (int c = 0; c < image.cols; ++c) {
      const float v = p[c];
      bad[c] = std::isfinite(v) ? 0 : 255;
      g[c] = std::isfinite(v) ? grey_of(v) : 0;
    }
  }
  cv::Mat view;
  cv::applyColorMap(grey, view, cv::COLORMAP_JET);
  view.setTo(kInvalidViewBgr, invalid);
  if (options.alpha) cv::cvtColor(view, view, cv::COLOR_BGR2BGRA);
  return view;
}

void WritePng(const std::string& path, const cv::Mat& image) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    throw FileError(path, "", "not written: expected a non-empty 8-bit 1- or 3-channel image");
  bool ok = false;
  std::string why;
  try {
    WriteFileAtomically(path, [&](const std::string& tmp) {
      if (!cv::imwrite(tmp, image)) throw FileError(path, "", "cannot write the PNG");
    });
    ok = true;
  } catch (const cv::Exception& e) {
    why = e.what();
  }
  if (!ok) throw FileError(path, "", "cannot write the PNG" + (why.empty() ? "" : ": " + why));
}

}  // namespace scancam
