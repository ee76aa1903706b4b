// ScanCam: writing output files without ever losing the user's data.
//
// Every file ScanCam writes (CLI and core writers: PLY/PCD/OBJ/GLB exports, PNG/TIFF images,
// JSON, pairs CSV, camera files, PTX, rotating logs, rawlogs) goes through
// WriteFileAtomically: the content is written to a temporary file in the output's own
// directory (".scancam-tmp-<random>-<name>", so extension-driven writers such as
// cv::imwrite pick the same format), flushed to disk, and renamed over the output in one
// step. A writer that fails or throws leaves the output as it was (absent, or the previous
// file) and removes the temporary. A symbolic link as output is followed: its target is
// replaced, the link stays. An existing output keeps its permission bits.
//
// OutputBatch (one per CLI run): while a batch is open, WriteFileAtomically only stages the
// temporary files; Commit() renames them all at the end of a successful run. A run that fails
// (the batch is destroyed uncommitted) removes its temporaries, so it leaves no output at all
// and every output of a previous run stays untouched. If a rename fails during Commit(), the
// outputs already renamed are put back (the previous files are kept as hard-linked backups
// until the commit is complete).
//
// CheckOutputs refuses, before any work, outputs that name an input (the same file, also
// through a symbolic or hard link: same device and inode; or the same canonical path when the
// output does not exist yet), two outputs naming the same file, outputs that are
// directories and outputs whose directory does not exist. It also hands the inputs to the
// open batch, which checks every output staged later against them (outputs whose names are
// only known during the run, e.g. `scancam ba`'s files).
#pragma once

#include <cstdio>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace scancam {

/// A command-line role and a path, e.g. {"--plot", "a.png"}; the role is quoted in messages.
struct NamedPath {
  std::string role;
  std::string path;
};

/// True when `a` and `b` are the same file (equivalent when both exist, else the same
/// weakly canonical path).
bool SameFile(const std::string& a, const std::string& b);

/// Throws scancam::Error (message naming both roles and paths) when an output is an input,
/// two outputs are the same file, an output is a directory or its directory is missing.
/// Empty paths are ignored. The inputs are remembered by the open OutputBatch, if any.
void CheckOutputs(const std::vector<NamedPath>& outputs, const std::vector<NamedPath>& inputs);

/// Writes `path` atomically: `write(tmp)` must write the whole file at `tmp` (throwing
/// scancam::Error on failure); then `tmp` replaces `path` (or is staged in the open
/// OutputBatch). Throws scancam::Error naming `path` when the temporary cannot be created,
/// synced or renamed.
void WriteFileAtomically(const std::string& path,
                         const std::function<void(const std::string& tmp)>& write);

/// The same for a file whose whole content is in memory.
void WriteFileAtomically(const std::string& path, std::string_view content);

/// The two-step form, for writers that open and stream into the file themselves: the
/// constructor creates the temporary file tmp() beside the output (throwing scancam::Error
/// as WriteFileAtomically does), Commit() flushes it to disk and renames it over the output
/// (or stages it in the open OutputBatch); destroyed uncommitted, it removes the temporary.
class AtomicFile {
 public:
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;
  const std::string& tmp() const { return tmp_; }
  void Commit();

 private:
  std::string path_, final_, tmp_;
  bool done_ = false;
};

/// A file written in pieces through an AtomicFile: text is appended to buffer() and Flush()
/// writes it to the temporary once it holds more than 1 MiB (always with force); Commit()
/// writes the rest, closes and commits. Throws scancam::Error naming `path` when the file
/// cannot be opened or written; destroyed uncommitted, it removes the temporary.
class StreamedFile {
 public:
  explicit StreamedFile(const std::string& path);
  ~StreamedFile();
  StreamedFile(const StreamedFile&) = delete;
  StreamedFile& operator=(const StreamedFile&) = delete;
  std::string& buffer() { return buffer_; }
  void Flush(bool force = false);
  void Commit();

 private:
  std::string path_;
  AtomicFile file_;
  std::FILE* f_ = nullptr;
  std::string buffer_;
};

/// The outputs of one run: see the header comment. At most one batch is open at a time.
class OutputBatch {
 public:
  OutputBatch();
  ~OutputBatch();  ///< uncommitted: removes the staged temporaries
  OutputBatch(const OutputBatch&) = delete;
  OutputBatch& operator=(const OutputBatch&) = delete;

  /// Renames every staged temporary over its output; throws scancam::Error (after putting
  /// back what it had renamed) when one cannot be renamed.
  void Commit();
  /// Outputs staged so far (final paths, in staging order).
  std::vector<std::string> staged() const;
};

/// For programs (the CLI): on SIGINT, SIGTERM, SIGHUP, SIGQUIT or SIGPIPE, remove every
/// temporary file this process has open (AtomicFile, staged outputs), then die of the signal
/// as without the handler. Outputs already renamed stay. A SIGKILL cannot be caught: its
/// temporaries (".scancam-tmp-*" beside the outputs) remain.
void RemoveTemporariesOnSignals();

}  // namespace scancam
