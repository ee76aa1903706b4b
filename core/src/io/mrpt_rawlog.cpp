// The MRPT rawlog reader's public functions, with MRPT decoding in an isolated child process;
// the stream and grid layers are in mrpt_rawlog_stream.cpp / mrpt_rawlog_grid.cpp.
#include "scancam/io/mrpt_rawlog.h"

#include <fcntl.h>
#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/opengl/CPointCloud.h>
#include <mrpt/poses/CPose3D.h>
#include <mrpt/serialization/CArchive.h>
#include <poll.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <new>
#include <type_traits>

#include "mrpt_rawlog_detail.h"
#include "scancam/error.h"
#include "scancam/output_file.h"

namespace scancam::io {

using namespace mrpt_detail;

namespace {

// ---------------------------------------------------------------- decoding in a child process

// MRPT trusts the sizes it reads from the stream: a damaged rawlog can make it allocate many
// GB or crash (SIGSEGV in CObservation3DRangeScan::rangeImage_setSize, found by mutating
// real rawlogs). So MRPT decodes in a forked child process, with its address space limited to
// what it had plus a budget from the uncompressed size, and hands back plain data through a
// pipe; a crash, a blown budget or an exception there becomes a FileError here.

// Byte (de)serialisation of what the child hands back.
class Packer {
 public:
  template <typename T>
  void Pod(const T& v) {
    static_assert(std::is_standard_layout<T>::value, "plain data only");
    out.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void Str(const std::string& v) {
    Pod<std::uint64_t>(v.size());
    out += v;
  }
  template <typename T>
  void Vec(const std::vector<T>& v) {
    Pod<std::uint64_t>(v.size());
    if (!v.empty()) out.append(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(T));
  }
  std::string out;
};

class Unpacker {
 public:
  explicit Unpacker(const std::string& in) : in_(in) {}
  template <typename T>
  T Pod() {
    T v;
    Take(&v, sizeof(T));
    return v;
  }
  std::string Str() {
    const auto n = Pod<std::uint64_t>();
    std::string v(Check(n, 1), '\0');
    Take(v.data(), v.size());
    return v;
  }
  template <typename T>
  std::vector<T> Vec() {
    const auto n = Pod<std::uint64_t>();
    std::vector<T> v(Check(n, sizeof(T)));
    if (!v.empty()) Take(v.data(), v.size() * sizeof(T));
    return v;
  }

 private:
  std::size_t Check(std::uint64_t n, std::size_t each) const {
    if (n > (in_.size() - pos_) / each) throw Error("internal: short reply from the MRPT decoder");
    return static_cast<std::size_t>(n);
  }
  void Take(void* dst, std::size_t n) {
    if (n > in_.size() - pos_) throw Error("internal: short reply from the MRPT decoder");
    std::memcpy(dst, in_.data() + pos_, n);
    pos_ += n;
  }
  const std::string& in_;
  std::size_t pos_ = 0;
};

void PackScan(Packer& p, const OrderedScan& s) {
  p.Pod(s.rows);
  p.Pod(s.cols);
  p.Vec(s.range_m);
  p.Vec(s.point_m);
  p.Vec(s.beam_dir);
  p.Vec(s.intensity);
  p.Pod(s.origin_m);
  p.Str(s.row_axis);
  p.Str(s.col_axis);
}

OrderedScan UnpackScan(Unpacker& u) {
  OrderedScan s;
  s.rows = u.Pod<int>();
  s.cols = u.Pod<int>();
  s.range_m = u.Vec<float>();
  s.point_m = u.Vec<Eigen::Vector3f>();
  s.beam_dir = u.Vec<Eigen::Vector3f>();
  s.intensity = u.Vec<float>();
  s.origin_m = u.Pod<Eigen::Vector3d>();
  s.row_axis = u.Str();
  s.col_axis = u.Str();
  return s;
}

}  // namespace

}  // namespace scancam::io

// ---------------------------------------------------------------- the budget in sanitizer builds

// Under a sanitizer (the fuzzers, the ASan test build) the child's address space cannot be
// limited: the sanitizers reserve terabytes of it up front, and under ASan a refused operator
// new is a fatal report, never std::bad_alloc. There the child counts what MRPT allocates
// through the sanitizer allocator's malloc hook (called after each allocation, before MRPT
// touches the memory) and leaves at once, without a report, when the budget is exceeded; the
// parent turns that into the same FileError as a std::bad_alloc in the release build. A
// sanitizer report in the child (e.g. an allocation too large for the machine, refused by the
// allocator itself) ends the child the same quiet way. Rationale and measurements: README
// "Fuzzing". In builds without a sanitizer none of this is compiled.
#if defined(__SANITIZE_ADDRESS__)
#define SCANCAM_RAWLOG_SANITIZED 1
#define SCANCAM_RAWLOG_ASAN 1
#elif defined(__SANITIZE_THREAD__)
#define SCANCAM_RAWLOG_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define SCANCAM_RAWLOG_SANITIZED 1
#define SCANCAM_RAWLOG_ASAN 1
#elif __has_feature(memory_sanitizer) || __has_feature(thread_sanitizer)
#define SCANCAM_RAWLOG_SANITIZED 1
#endif
#endif

#ifdef SCANCAM_RAWLOG_SANITIZED
// The sanitizer runtimes' interface (sanitizer/allocator_interface.h and
// sanitizer/common_interface_defs.h of the compiler).
extern "C" {
int __sanitizer_install_malloc_and_free_hooks(void (*malloc_hook)(const volatile void*,
                                                                  std::size_t),
                                              void (*free_hook)(const volatile void*));
std::size_t __sanitizer_get_current_allocated_bytes(void);
void __sanitizer_set_death_callback(void (*callback)(void));
}
#endif

namespace scancam::io {
namespace {

// Exit status of a child that ends itself over the budget or on a sanitizer report (the
// parent reads DecodeWhere::ended_by for which).
constexpr int kChildEndedExit = 86;

#ifdef SCANCAM_RAWLOG_SANITIZED
constexpr bool kSanitized = true;

// The child's budget; `active` only in a decoding child, so the hooks do nothing elsewhere.
struct ChildBudget {
  bool active = false;
  std::size_t budget_bytes = 0;  // for one allocation
  std::size_t limit_bytes = 0;   // allocated bytes in all (the sanitizer's count)
  unsigned calls = 0;
};
ChildBudget g_budget;

[[noreturn]] void EndChild(int why) {
  if (g_where) g_where->ended_by = why;
  _exit(kChildEndedExit);
}

void BudgetMallocHook(const volatile void*, std::size_t size) {
  if (!g_budget.active) return;
  // Large allocations at once, the running total also every 1024 small ones.
  if (size < (std::size_t{1} << 20) && (++g_budget.calls & 1023u) != 0) return;
  if (size > g_budget.budget_bytes ||
      __sanitizer_get_current_allocated_bytes() > g_budget.limit_bytes) {
    g_budget.active = false;
    EndChild(1);
  }
}

void NoFreeHook(const volatile void*) {}

void ChildDeathCallback() {
  if (g_budget.active) EndChild(2);
}

void StartChildBudget(std::size_t budget) {
  g_budget.budget_bytes = budget;
  g_budget.limit_bytes = __sanitizer_get_current_allocated_bytes() + budget;
  g_budget.calls = 0;
  g_budget.active = true;
  // The hooks are installed in the child only (its own copy of the hook table). A death
  // callback ends the child before libFuzzer's (which would save the input as a finding).
  __sanitizer_install_malloc_and_free_hooks(BudgetMallocHook, NoFreeHook);
  __sanitizer_set_death_callback(ChildDeathCallback);
}
#else
constexpr bool kSanitized = false;
void StartChildBudget(std::size_t) {}
#endif

}  // namespace
}  // namespace scancam::io

#ifdef SCANCAM_RAWLOG_ASAN
// ASan calls this before it prints a report (symbolising the stack takes ~1 s): a report in
// the decoding child ends the child at once. Elsewhere it does nothing.
extern "C" void __asan_on_error() {
  if (scancam::io::g_budget.active) scancam::io::EndChild(2);
}
#endif

namespace scancam::io {
namespace {

std::size_t VirtualMemoryBytes() {
  std::ifstream statm("/proc/self/statm");
  std::size_t pages = 0;
  statm >> pages;
  return pages * static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
}

void WriteAll(int fd, const std::string& s) {
  std::size_t done = 0;
  while (done < s.size()) {
    const ssize_t w = ::write(fd, s.data() + done, s.size() - done);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return;
    done += static_cast<std::size_t>(w);
  }
}

// The error of a child that went over its memory budget `budget_bytes` at `w`.
Error OverBudget(const std::string& path, const DecodeWhere& w, std::size_t budget_bytes) {
  return FileError(path, ObjectWhere(w.object_index, static_cast<std::size_t>(w.offset)),
                   "MRPT asked for more memory than this rawlog can hold (over " +
                       std::to_string(budget_bytes >> 20) +
                       " MiB while decoding it): the file is damaged");
}

// Runs `decode` (which returns a Packer's bytes) in a child process and returns its bytes;
// rethrows its error message; a crash or a blown memory / CPU budget becomes a FileError
// naming the object being decoded.
template <typename Decode>
std::string DecodeIsolated(const std::string& path, const RawlogBytes& bytes,
                           const Decode& decode) {
  CheckFirstObjectHeader(path, bytes);  // what MRPT refuses at once needs no process
  const std::size_t budget = (std::size_t{512} << 20) + 16 * bytes.data.size();
  void* page =
      mmap(nullptr, sizeof(DecodeWhere), PROT_READ | PROT_WRITE, MAP_SHARED | MAP_ANONYMOUS, -1, 0);
  if (page == MAP_FAILED) throw FileError(path, "", "cannot map memory for the MRPT decoder");
  struct Unmap {
    void* p;
    ~Unmap() { munmap(p, sizeof(DecodeWhere)); }
  } unmap{page};
  DecodeWhere* where = new (page) DecodeWhere();
  // CPU seconds for the child; the parent waits at most that long plus a margin in real time.
  const rlim_t cpu_s = 60 + static_cast<rlim_t>(bytes.data.size() >> 20);
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0)
    throw FileError(path, "", "cannot create a pipe for the MRPT decoder");
  const std::size_t vm = VirtualMemoryBytes();
  const pid_t pid = fork();
  if (pid < 0) {
    close(fds[0]);
    close(fds[1]);
    throw FileError(path, "", "cannot start the MRPT decoder process");
  }
  if (pid == 0) {
    // Child: decode, write 'O' + data or 'E' + message, leave without running any atexit
    // handler or destructor of the parent's objects.
    close(fds[0]);
    if (kSanitized) {
      StartChildBudget(budget);  // the address space cannot be limited (see above)
    } else {
      const rlimit as{vm + budget, vm + budget};
      setrlimit(RLIMIT_AS, &as);
    }
    const rlimit cpu{cpu_s, cpu_s + 5};
    setrlimit(RLIMIT_CPU, &cpu);
    // A crash ends the child, whatever handler the host application (CloudCompare's crash
    // reporter, a sanitizer) installed for the whole process.
    for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT}) signal(sig, SIG_DFL);
    g_where = where;
    std::string reply;
    try {
      reply = "O" + decode();
    } catch (const std::bad_alloc&) {
      reply = std::string("E") + OverBudget(path, *where, budget).what();
    } catch (const std::exception& e) {
      reply = std::string("E") + e.what();
    } catch (...) {
      reply = "E" + path + ": unknown error while decoding the rawlog";
    }
    WriteAll(fds[1], reply);
    close(fds[1]);
    _exit(0);
  }
  close(fds[1]);
  std::string reply;
  char buf[1 << 16];
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2 * cpu_s + 30);
  bool timed_out = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) {
      timed_out = true;  // e.g. stuck on a lock another thread held at fork()
      kill(pid, SIGKILL);
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    const int ready = poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready == 0) continue;
    const ssize_t r = ::read(fds[0], buf, sizeof buf);
    if (r < 0 && errno == EINTR) continue;
    if (r <= 0) break;
    reply.append(buf, static_cast<std::size_t>(r));
  }
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  const DecodeWhere w = *where;
  const std::string at = ObjectWhere(w.object_index, static_cast<std::size_t>(w.offset));
  const std::string doing =
      w.stage == 0 ? "decoding this object" : "converting the observations read";
  if (WIFEXITED(status) && WEXITSTATUS(status) == kChildEndedExit && w.ended_by == 1) {
    throw OverBudget(path, w, budget);
  }
  if (WIFSIGNALED(status) || !WIFEXITED(status) || WEXITSTATUS(status) != 0 || reply.empty()) {
    const int sig = WIFSIGNALED(status) ? WTERMSIG(status) : 0;
    if (sig == SIGXCPU || timed_out) {
      throw FileError(path, at, "MRPT took too long " + doing + ": the file is damaged");
    }
    const bool reported =
        WIFEXITED(status) && WEXITSTATUS(status) == kChildEndedExit && w.ended_by == 2;
    const std::string name =
        sig ? std::string(strsignal(sig))
        : reported
            ? std::string("stopped by the sanitizer: a memory error or an allocation too large")
            : (WIFEXITED(status) && WEXITSTATUS(status) != 0
                   ? "exit code " + std::to_string(WEXITSTATUS(status))
                   : std::string("no reply"));
    throw FileError(path, at,
                    "MRPT crashed (" + name + ") " + doing +
                        ": the file is damaged or not a rawlog (ScanCam itself goes on)");
  }
  if (reply[0] == 'E') throw Error(reply.substr(1));
  return reply.substr(1);
}

}  // namespace

std::vector<RawlogScanEntry> ListRawlogScans(const std::string& path) {
  const RawlogBytes bytes = ReadRawlogBytes(path);
  const std::string reply = DecodeIsolated(path, bytes, [&] {
    const Loaded l = LoadEntries(path, bytes);
    Packer p;
    p.Pod<std::uint64_t>(l.entries.size());
    for (const Entry& e : l.entries) {
      p.Pod(e.info.index);
      p.Pod(e.info.first_object);
      p.Str(e.info.class_name);
      p.Str(e.info.sensor_label);
      p.Pod(e.info.mrpt_rows);
      p.Pod(e.info.mrpt_cols);
      p.Str(e.info.lidar_model);
      p.Pod(e.info.mrpt_points);
    }
    return p.out;
  });
  Unpacker u(reply);
  std::vector<RawlogScanEntry> out(static_cast<std::size_t>(u.Pod<std::uint64_t>()));
  for (RawlogScanEntry& e : out) {
    e.index = u.Pod<int>();
    e.first_object = u.Pod<int>();
    e.class_name = u.Str();
    e.sensor_label = u.Str();
    e.mrpt_rows = u.Pod<int>();
    e.mrpt_cols = u.Pod<int>();
    e.lidar_model = u.Str();
    e.mrpt_points = u.Pod<int>();
  }
  return out;
}

std::string RawlogUncompressedBytes(const std::string& path) { return ReadRawlogBytes(path).data; }

OrderedScan LoadMrptRawlog(const std::string& path, int rawlog_index, const Progress& progress) {
  progress(0.0, "reading rawlog");
  const RawlogBytes bytes = ReadRawlogBytes(path);
  progress(0.2, "reading rawlog");
  const std::string reply = DecodeIsolated(path, bytes, [&] {
    Loaded l = LoadEntries(path, bytes);
    const Entry& e = PickEntry(path, l.entries, l.objects, l.obs.size(), rawlog_index);
    const ObsRecord& rec = l.obs[e.records[0]];
    if (g_where) *g_where = {1, rec.object_index, rec.offset};
    const std::string where = ObjectWhere(rec.object_index, rec.offset);
    OrderedScan scan;
    switch (e.kind) {
      case Kind::kRotating: {
        const auto& rot = dynamic_cast<const CObservationRotatingScan&>(*rec.obs);
        scan = RotatingToScan(path, where, rot, nullptr).scan;
        break;
      }
      case Kind::kVelodyne: {
        auto& v = dynamic_cast<CObservationVelodyneScan&>(*rec.obs);
        const CObservationRotatingScan rot = FromVelodyne(path, rec, v);
        RotatingGrid g = RotatingToScan(path, where, rot, &v.calibration);
        UseMrptVelodynePoints(v, g);
        scan = std::move(g.scan);
        break;
      }
      case Kind::k3D: {
        auto& d = dynamic_cast<CObservation3DRangeScan&>(*rec.obs);
        scan = DepthToScan(path, where, d);
        break;
      }
      case Kind::k2D:
        scan = StackScans(path, l.obs, e, nullptr);
        break;
    }
    if (scan.valid_count() == 0) {
      throw FileError(path, where, e.info.class_name + " has no valid range (every cell empty)");
    }
    Packer p;
    PackScan(p, scan);
    return p.out;
  });
  Unpacker u(reply);
  OrderedScan scan = UnpackScan(u);
  scan.source = path;
  progress(1.0, "reading rawlog");
  return scan;
}

std::vector<Eigen::Vector3f> MrptReferencePoints(const std::string& path, int rawlog_index) {
  const RawlogBytes bytes = ReadRawlogBytes(path);
  const std::string reply = DecodeIsolated(path, bytes, [&] {
    Loaded l = LoadEntries(path, bytes);
    const Entry& e = PickEntry(path, l.entries, l.objects, l.obs.size(), rawlog_index);
    const ObsRecord& rec = l.obs[e.records[0]];
    std::vector<Eigen::Vector3f> out;
    switch (e.kind) {
      case Kind::kRotating:
        break;
      case Kind::kVelodyne: {
        for (const VeloPoint& p :
             VelodynePoints(dynamic_cast<CObservationVelodyneScan&>(*rec.obs))) {
          out.emplace_back(p.x, p.y, p.z);
        }
        break;
      }
      case Kind::k3D: {
        auto& d = dynamic_cast<CObservation3DRangeScan&>(*rec.obs);
        mrpt::opengl::CPointCloud cloud;
        mrpt::obs::T3DPointsProjectionParams pp;
        pp.USE_SSE2 = false;
        d.unprojectInto(cloud, pp);
        for (std::size_t i = 0; i < cloud.size(); ++i) {
          const auto& q = cloud.getPoint3Df(i);
          out.emplace_back(q.x, q.y, q.z);
        }
        break;
      }
      case Kind::k2D:
        StackScans(path, l.obs, e, &out);
        break;
    }
    Packer p;
    p.Vec(out);
    return p.out;
  });
  Unpacker u(reply);
  return u.Vec<Eigen::Vector3f>();
}

void WriteMrpt2DScanRawlog(const std::string& path, const RotatingScanData& data,
                           const std::string& sensor_label) {
  CheckRotatingScanData(data, path);
  const int m = data.beams;
  const double aperture = m > 1 ? data.theta_rad[m - 1] - data.theta_rad[0] : 0.0;
  for (int j = 0; j < m && m > 1; ++j) {
    const double expect = -aperture / 2 + j * aperture / (m - 1);
    if (std::abs(data.theta_rad[j] - expect) > 1e-9) {
      throw FileError(path, "",
                      "beam " + std::to_string(j) + " angle " + std::to_string(data.theta_rad[j]) +
                          " is not -A/2 + j A/(M-1) = " + std::to_string(expect) +
                          ": an MRPT 2D scan's beams are evenly spread and centred");
    }
  }
  float max_range = 1.f;
  for (float r : data.range_m) {
    if (std::isfinite(r)) max_range = std::max(max_range, r);
  }
  AtomicFile file(path);
  mrpt::io::CFileGZOutputStream out;
  if (!out.open(file.tmp())) throw FileError(path, "", "cannot open the file for writing");
  auto ar = mrpt::serialization::archiveFrom(out);
  try {
    for (int i = 0; i < data.planes; ++i) {
      CObservation2DRangeScan o;
      o.sensorLabel = sensor_label;
      o.timestamp = mrpt::Clock::fromDouble(1.0e9 + 0.01 * i);
      o.aperture = static_cast<float>(aperture);
      o.rightToLeft = true;
      o.maxRange = 2.f * max_range;
      o.resizeScan(static_cast<std::size_t>(m));
      const bool intensity = !data.intensity.empty();
      if (intensity) o.setScanHasIntensity(true);
      for (int j = 0; j < m; ++j) {
        const float r = data.range(i, j);
        const bool valid = std::isfinite(r) && r > 0.f;
        o.setScanRange(static_cast<std::size_t>(j), valid ? r : 0.f);
        o.setScanRangeValidity(static_cast<std::size_t>(j), valid);
        if (intensity) {
          o.setScanIntensity(
              static_cast<std::size_t>(j),
              static_cast<int>(std::lround(data.intensity[static_cast<std::size_t>(i) * m + j])));
        }
      }
      // Eq. 3: the plane is the sensor plane pitched by phi_i about y, its centre at
      // R_y(phi_i) (d_x, 0, d_z).
      const double phi = data.phi_rad[i];
      const double c = std::cos(phi), s = std::sin(phi);
      o.sensorPose = mrpt::poses::CPose3D(c * data.dx_m + s * data.dz_m, 0.0,
                                          -s * data.dx_m + c * data.dz_m, 0.0, phi, 0.0);
      ar << o;
    }
  } catch (const std::exception& e) {
    throw FileError(path, "", "MRPT could not write the rawlog (" + MrptMessage(e) + ")");
  }
  out.close();
  file.Commit();
}

}  // namespace scancam::io
