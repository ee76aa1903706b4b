#include "scancam/output_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <random>

#include "scancam/error.h"

namespace scancam {

namespace fs = std::filesystem;

namespace {

struct Staged {
  std::string tmp;
  std::string final_path;
};

struct BatchState {
  std::vector<NamedPath> inputs;
  std::vector<Staged> staged;
};

std::mutex g_mutex;
BatchState* g_batch = nullptr;

// The temporaries that exist now, in a fixed table that a signal handler can walk without
// allocating or locking (RemoveTemporariesOnSignals). A slot is 0 free, 1 being filled, 2 live.
constexpr int kMaxLive = 256;
constexpr std::size_t kLivePathMax = 4096;
struct LiveSlot {
  std::atomic<int> state{0};
  char path[kLivePathMax];
};
LiveSlot g_live[kMaxLive];

void RememberTemp(const std::string& path) {
  if (path.size() >= kLivePathMax) return;
  for (LiveSlot& slot : g_live) {
    int expected = 0;
    if (slot.state.compare_exchange_strong(expected, 1)) {
      std::memcpy(slot.path, path.c_str(), path.size() + 1);
      slot.state.store(2);
      return;
    }
  }
}

void ForgetTemp(const std::string& path) {
  for (LiveSlot& slot : g_live) {
    if (slot.state.load() == 2 && path == slot.path) {
      slot.state.store(0);
      return;
    }
  }
}

// Removes (or renames) a temporary and forgets it.
void RemoveTemp(const std::string& tmp) {
  std::remove(tmp.c_str());
  ForgetTemp(tmp);
}

extern "C" void RemoveTemporariesAndDie(int sig) {
  for (LiveSlot& slot : g_live) {
    if (slot.state.load() == 2) ::unlink(slot.path);
  }
  ::signal(sig, SIG_DFL);
  ::raise(sig);
}

std::string Quoted(const NamedPath& p) { return p.role + " '" + p.path + "'"; }

// The file an output path really names: a symbolic link is followed (its target replaced).
std::string ResolveOutput(const std::string& path) {
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(path, ec))) {
    const fs::path target = fs::weakly_canonical(path, ec);
    if (!ec) return target.string();
  }
  return path;
}

std::string RandomTag() {
  static std::mutex m;
  static std::mt19937_64 rng(std::random_device{}() ^
                             static_cast<std::uint64_t>(::getpid()) * 0x9E3779B97F4A7C15ull);
  std::lock_guard<std::mutex> lock(m);
  char buf[24];
  std::snprintf(buf, sizeof buf, "%012llx",
                static_cast<unsigned long long>(rng() & 0xffffffffffffull));
  return buf;
}

constexpr char kTempPrefix[] = ".scancam-tmp-";

// A run killed by SIGKILL (which no handler sees) leaves its temporaries. The next run that
// writes the same output removes those of `filename` whose writer is gone: the name carries the
// writer's process id, that process no longer exists here, and the file has not changed for
// 10 minutes (so a run on another machine sharing the directory is never touched). Nothing but
// `.scancam-tmp-<pid>-<tag>-<filename>` is ever removed.
void RemoveStaleTemporaries(const fs::path& dir, const std::string& filename) {
  std::error_code ec;
  fs::directory_iterator it(dir.empty() ? fs::path(".") : dir, ec), end;
  const std::string suffix = "-" + filename;
  const auto now = fs::file_time_type::clock::now();
  for (int seen = 0; !ec && it != end && seen < 100000; it.increment(ec), ++seen) {
    const std::string name = it->path().filename().string();
    if (name.size() <= sizeof kTempPrefix - 1 + suffix.size() ||
        name.compare(0, sizeof kTempPrefix - 1, kTempPrefix) != 0 ||
        name.compare(name.size() - suffix.size(), suffix.size(), suffix) != 0)
      continue;
    const char* p = name.c_str() + sizeof kTempPrefix - 1;
    char* after = nullptr;
    errno = 0;
    const long pid = std::strtol(p, &after, 10);
    if (errno != 0 || after == p || *after != '-' || pid <= 0 || pid == ::getpid()) continue;
    if (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;  // still alive
    std::error_code e2;
    if (!it->is_regular_file(e2) || e2) continue;
    const auto written = fs::last_write_time(it->path(), e2);
    if (e2 || now - written < std::chrono::minutes(10)) continue;
    fs::remove(it->path(), e2);
  }
}

// Creates an empty temporary file beside `final_path`; returns its path.
std::string CreateTemp(const std::string& final_path) {
  const fs::path f(final_path);
  const fs::path dir = f.parent_path();
  RemoveStaleTemporaries(dir, f.filename().string());
  for (int attempt = 0; attempt < 100; ++attempt) {
    const fs::path tmp = dir / (kTempPrefix + std::to_string(::getpid()) + "-" + RandomTag() + "-" +
                                f.filename().string());
    const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) {
      struct stat st;
      if (::stat(final_path.c_str(), &st) == 0 && S_ISREG(st.st_mode)) {
        ::fchmod(fd, st.st_mode & 07777);  // keep the permissions of the file replaced
      }
      ::close(fd);
      RememberTemp(tmp.string());
      return tmp.string();
    }
    if (errno != EEXIST) {
      throw FileError(final_path, "",
                      std::string("cannot create a temporary file in its directory (") +
                          std::strerror(errno) + ")");
    }
  }
  throw FileError(final_path, "", "cannot create a temporary file in its directory");
}

void SyncFile(const std::string& tmp, const std::string& final_path) {
  const int fd = ::open(tmp.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    throw FileError(final_path, "", "the writer left no file (temporary " + tmp + " vanished)");
  }
  const int rc = ::fsync(fd);
  ::close(fd);
  if (rc != 0) {
    throw FileError(final_path, "",
                    std::string("cannot flush the file to disk (") + std::strerror(errno) + ")");
  }
}

void CheckNotInput(const std::vector<NamedPath>& inputs, const std::string& output) {
  for (const NamedPath& in : inputs) {
    if (!in.path.empty() && SameFile(output, in.path)) {
      throw FileError(output, "",
                      "refusing to write: this output is the input " + Quoted(in) +
                          " (the same file); choose another output name");
    }
  }
}

}  // namespace

bool SameFile(const std::string& a, const std::string& b) {
  std::error_code ea, eb;
  const bool xa = fs::exists(a, ea), xb = fs::exists(b, eb);
  if (xa && xb) {
    std::error_code ec;
    return fs::equivalent(a, b, ec);
  }
  if (xa != xb) return false;
  std::error_code ec1, ec2;
  const fs::path ca = fs::weakly_canonical(a, ec1), cb = fs::weakly_canonical(b, ec2);
  if (ec1 || ec2) return fs::absolute(a).lexically_normal() == fs::absolute(b).lexically_normal();
  return ca == cb;
}

void CheckOutputs(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs) {
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    if (g_batch) g_batch->inputs.insert(g_batch->inputs.end(), inputs.begin(), inputs.end());
  }
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    const NamedPath& out = outputs[i];
    if (out.path.empty()) continue;
    for (const NamedPath& in : inputs) {
      if (!in.path.empty() && SameFile(out.path, in.path)) {
        throw Error(Quoted(out) + " is the input " + Quoted(in) +
                    " (the same file): an output never overwrites an input; choose another "
                    "output name");
      }
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (!outputs[j].path.empty() && SameFile(out.path, outputs[j].path)) {
        throw Error(Quoted(out) + " and " + Quoted(outputs[j]) +
                    " are the same file: give each output its own name");
      }
    }
    std::error_code ec;
    if (fs::is_directory(out.path, ec)) {
      throw Error(Quoted(out) + " is a directory, not a file name");
    }
    const fs::path dir = fs::path(out.path).parent_path();
    if (!dir.empty() && !fs::is_directory(dir, ec)) {
      throw Error(Quoted(out) + ": the directory '" + dir.string() + "' does not exist");
    }
  }
}

AtomicFile::AtomicFile(const std::string& path) : path_(path) {
  if (path.empty()) throw Error("empty output file name");
  final_ = ResolveOutput(path);
  {
    std::lock_guard<std::mutex> lock(g_mutex);
    if (g_batch) {
      CheckNotInput(g_batch->inputs, final_);
      for (const Staged& s : g_batch->staged) {
        if (SameFile(s.final_path, final_)) {
          throw FileError(path, "", "written twice in one run (two outputs name this file)");
        }
      }
    }
  }
  std::error_code ec;
  if (fs::is_directory(final_, ec)) throw FileError(path, "", "is a directory, not a file name");
  tmp_ = CreateTemp(final_);
}

AtomicFile::~AtomicFile() {
  if (!done_) RemoveTemp(tmp_);
}

void AtomicFile::Commit() {
  if (done_) return;
  SyncFile(tmp_, path_);
  std::lock_guard<std::mutex> lock(g_mutex);
  done_ = true;
  if (g_batch) {
    g_batch->staged.push_back({tmp_, final_});
    return;
  }
  if (std::rename(tmp_.c_str(), final_.c_str()) != 0) {
    const int err = errno;
    RemoveTemp(tmp_);
    throw FileError(path_, "", std::string("cannot replace the file (") + std::strerror(err) + ")");
  }
}

StreamedFile::StreamedFile(const std::string& path) : path_(path), file_(path) {
  f_ = std::fopen(file_.tmp().c_str(), "wb");
  if (!f_) throw FileError(path, "", "cannot open the file for writing");
}

StreamedFile::~StreamedFile() {
  if (f_) std::fclose(f_);
}

void StreamedFile::Flush(bool force) {
  if (buffer_.size() <= (1u << 20) && !(force && !buffer_.empty())) return;
  if (std::fwrite(buffer_.data(), 1, buffer_.size(), f_) != buffer_.size()) {
    throw FileError(path_, "", "write error (disk full?)");
  }
  buffer_.clear();
}

void StreamedFile::Commit() {
  Flush(true);
  const bool ok = std::fclose(f_) == 0;
  f_ = nullptr;
  if (!ok) throw FileError(path_, "", "write error (disk full?)");
  file_.Commit();
}

void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmp)>& write) {
  AtomicFile file(path);
  write(file.tmp());
  file.Commit();
}

void WriteFileAtomically(const std::string& path, std::string_view content) {
  WriteFileAtomically(path, [&](const std::string& tmp) {
    std::FILE* f = std::fopen(tmp.c_str(), "wb");
    if (!f) throw FileError(path, "", "cannot open the file for writing");
    const bool ok = std::fwrite(content.data(), 1, content.size(), f) == content.size();
    if (std::fclose(f) != 0 || !ok) throw FileError(path, "", "write error (disk full?)");
  });
}

OutputBatch::OutputBatch() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (g_batch) throw Error("internal: an output batch is already open");
  g_batch = new BatchState();
}

OutputBatch::~OutputBatch() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_batch) return;
  for (const Staged& s : g_batch->staged) RemoveTemp(s.tmp);
  delete g_batch;
  g_batch = nullptr;
}

std::vector<std::string> OutputBatch::staged() const {
  std::lock_guard<std::mutex> lock(g_mutex);
  std::vector<std::string> out;
  if (g_batch) {
    for (const Staged& s : g_batch->staged) out.push_back(s.final_path);
  }
  return out;
}

void OutputBatch::Commit() {
  std::lock_guard<std::mutex> lock(g_mutex);
  if (!g_batch) return;
  std::vector<Staged>& staged = g_batch->staged;
  // Keep every file about to be replaced as a hard-linked backup until all renames are done.
  std::vector<std::string> backup(staged.size());
  for (std::size_t i = 0; i < staged.size(); ++i) {
    struct stat st;
    if (::lstat(staged[i].final_path.c_str(), &st) != 0) continue;
    const fs::path f(staged[i].final_path);
    const std::string b =
        (f.parent_path() / (".scancam-old-" + RandomTag() + "-" + f.filename().string())).string();
    if (::link(staged[i].final_path.c_str(), b.c_str()) == 0) backup[i] = b;
  }
  std::size_t done = 0;
  for (; done < staged.size(); ++done) {
    if (std::rename(staged[done].tmp.c_str(), staged[done].final_path.c_str()) != 0) break;
    ForgetTemp(staged[done].tmp);
  }
  if (done < staged.size()) {
    const int err = errno;
    const std::string failed = staged[done].final_path;
    for (std::size_t i = 0; i < done; ++i) {  // put back what this run had replaced
      if (!backup[i].empty()) {
        std::rename(backup[i].c_str(), staged[i].final_path.c_str());
        backup[i].clear();
      } else {
        std::remove(staged[i].final_path.c_str());
      }
    }
    for (std::size_t i = done; i < staged.size(); ++i) RemoveTemp(staged[i].tmp);
    for (const std::string& b : backup)
      if (!b.empty()) std::remove(b.c_str());
    staged.clear();
    throw FileError(failed, "",
                    std::string("cannot replace the file (") + std::strerror(err) +
                        "); no output of this run was kept");
  }
  for (const std::string& b : backup)
    if (!b.empty()) std::remove(b.c_str());
  staged.clear();
}

void RemoveTemporariesOnSignals() {
  struct sigaction sa;
  std::memset(&sa, 0, sizeof sa);
  sa.sa_handler = RemoveTemporariesAndDie;
  sigemptyset(&sa.sa_mask);
  for (int sig : {SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE}) ::sigaction(sig, &sa, nullptr);
}

}  // namespace scancam
