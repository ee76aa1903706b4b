// ScanCam simulator: laser scanners that sample a Scene.
//
// Two sensors, each a grid of beams (row, col) in the scanner frame (x forward, z up, metres):
//
//   RotatingScanner  the paper's rotating SICK (docs/method.md eq. 3, io/rotating_log.h): row i =
//                    scan plane phi_i = phi0 + i * dphi, column j = beam theta_j = theta0 +
//                    j * dtheta; beam (i, j) leaves o_i = (c_i dx + s_i dz, 0, -s_i dx + c_i dz)
//                    along b_ij = (c_i c_j, s_j, -s_i c_j). Default: 360 planes every 1 deg
//                    (phi in [0, 359]), 361 beams every 0.5 deg (theta in [-90, 90]).
//   SpinningLidar    a multi-beam lidar (e.g. 64 rings), single origin (0, 0, 0): row r = ring
//                    at elevation top - r * (top - bottom) / (rings - 1) (row 0 highest),
//                    column c = azimuth 180 deg - (c + 0.5) * step (decreasing from left to
//                    right, as io/regrid.h orders rings), azimuth = atan2(y, x).
//
// Measurement model (both): the true range is the exact ray-cast distance to the first
// surface; the measured range adds Gaussian noise N(0, range_sigma_m); a return is dropped
// (no return) with probability dropout_fraction, or when the true range exceeds max_range_m or
// is below min_range_m. Intensity = the surface's reflectance (scene.h) in [0, 1]. No mixed
// pixels, no beam divergence: a beam hits one surface point.
//
// Noise is drawn in a fixed order (cell by cell, row-major) from a generator seeded by `seed`,
// so a seed gives the same scan on every run (casting is parallel, noise is not).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "scancam/io/rotating_log.h"
#include "scancam/ordered_scan.h"
#include "scancam/progress.h"
#include "scancam/sim/scene.h"

namespace scancam::sim {

struct RangeNoise {
  double range_sigma_m = 0.003;
  double dropout_fraction = 0.002;
  double max_range_m = 30.0;
  double min_range_m = 0.1;
};

/// Beam geometry of a scanner: a grid of rows x cols beams.
class SimScanner {
 public:
  virtual ~SimScanner() = default;
  virtual int rows() const = 0;
  virtual int cols() const = 0;
  /// Origin and unit direction of beam (row, col), scanner frame.
  virtual void Beam(int row, int col, Eigen::Vector3d* origin, Eigen::Vector3d* dir) const = 0;
  /// The fractional cell (row, col) whose beam passes through the scanner-frame point p, i.e.
  /// the inverse of Beam() continued linearly between cells; nullopt when p is outside the
  /// angular span of the grid (not within half a cell of it) or at the origin.
  virtual std::optional<Eigen::Vector2d> CellOf(const Eigen::Vector3d& p) const = 0;
  /// Largest angular step between neighbouring cells (rad).
  virtual double MaxStepRad() const = 0;
  /// A description for files ("rotating", "lidar") and the OrderedScan axes.
  virtual std::string Kind() const = 0;
  virtual std::string RowAxis() const = 0;
  virtual std::string ColAxis() const = 0;
};

struct RotatingScannerParams {
  int planes = 360;
  double phi0_deg = 0.0;
  double phi_step_deg = 1.0;
  int beams = 361;
  double theta0_deg = -90.0;
  double theta_step_deg = 0.5;
  double dx_m = 0.02;  ///< eq. 3 offsets of the rotation axis from the mirror centre
  double dz_m = 0.08;
};

class RotatingScanner : public SimScanner {
 public:
  explicit RotatingScanner(const RotatingScannerParams& p);
  int rows() const override { return p_.planes; }
  int cols() const override { return p_.beams; }
  void Beam(int row, int col, Eigen::Vector3d* origin, Eigen::Vector3d* dir) const override;
  std::optional<Eigen::Vector2d> CellOf(const Eigen::Vector3d& p) const override;
  double MaxStepRad() const override;
  std::string Kind() const override { return "rotating"; }
  std::string RowAxis() const override { return "scan plane i (phi)"; }
  std::string ColAxis() const override { return "beam j (theta)"; }
  const RotatingScannerParams& params() const { return p_; }

 private:
  RotatingScannerParams p_;
};

struct SpinningLidarParams {
  int rings = 64;
  double elevation_top_deg = 2.0;
  double elevation_bottom_deg = -24.8;
  double azimuth_step_deg = 0.2;  ///< columns = round(360 / step)
};

class SpinningLidar : public SimScanner {
 public:
  explicit SpinningLidar(const SpinningLidarParams& p);
  int rows() const override { return p_.rings; }
  int cols() const override { return cols_; }
  void Beam(int row, int col, Eigen::Vector3d* origin, Eigen::Vector3d* dir) const override;
  std::optional<Eigen::Vector2d> CellOf(const Eigen::Vector3d& p) const override;
  double MaxStepRad() const override;
  std::string Kind() const override { return "lidar"; }
  std::string RowAxis() const override { return "ring (elevation, row 0 highest)"; }
  std::string ColAxis() const override { return "azimuth (decreasing left to right)"; }
  const SpinningLidarParams& params() const { return p_; }

 private:
  SpinningLidarParams p_;
  int cols_ = 0;
};

/// What the simulator knows about every cell, beyond what the scan file holds.
struct ScanTruth {
  int rows = 0, cols = 0;
  std::vector<Eigen::Vector3d> point_m;  ///< exact surface point hit, scanner frame (NaN: no hit)
  std::vector<int> quad;                 ///< quad hit (-1: none)
  std::vector<std::uint8_t> valid;       ///< the scan has a return in this cell
  std::vector<Eigen::Vector3f> colour;   ///< true colour (scene.h) of the hit, RGB 0..255
  std::vector<std::uint8_t> visible;     ///< seen by the camera (set by the caller)
  std::size_t index(int r, int c) const { return std::size_t(r) * std::size_t(cols) + c; }
};

/// Casts every beam of `scanner` placed at T_world_scan in `scene`; returns the measured
/// ranges (row-major, NaN = no return), intensities, and the truth (without visibility).
struct ScanSample {
  std::vector<float> range_m;
  std::vector<float> intensity;
  ScanTruth truth;
};
ScanSample SampleScan(const Scene& scene, const SimScanner& scanner,
                      const Eigen::Isometry3d& T_world_scan, const RangeNoise& noise,
                      std::uint64_t seed, const Progress& progress = {});

/// The same in blocks of rows, in order, for scans too large to hold: Next(count) casts rows
/// [next_row(), next_row() + count) and returns them as a sample of `count` rows (truth.rows
/// = count); the blocks put together are exactly SampleScan's sample (noise drawn cell by cell
/// from one generator across blocks). The scene and scanner must outlive the sampler.
class RowSampler {
 public:
  RowSampler(const Scene& scene, const SimScanner& scanner, const Eigen::Isometry3d& T_world_scan,
             const RangeNoise& noise, std::uint64_t seed);
  ~RowSampler();
  ScanSample Next(int count, const Progress& progress = {});
  int next_row() const { return next_row_; }

 private:
  struct Rng;
  const Scene& scene_;
  const SimScanner& scanner_;
  Eigen::Isometry3d T_world_scan_;
  RangeNoise noise_;
  std::unique_ptr<Rng> rng_;
  int next_row_ = 0;
};

/// The exact surface point (scanner frame) beam (row, col) hits, or nullopt; what the truth of
/// SampleScan holds for that cell.
std::optional<Eigen::Vector3d> TruthPoint(const Scene& scene, const SimScanner& scanner,
                                          const Eigen::Isometry3d& T_world_scan, int row, int col);

/// The rotating scanner's log data (for WriteRotatingLog / ToOrderedScan) of a sample.
/// With first_plane: the sample holds planes [first_plane, first_plane + sample.truth.rows).
io::RotatingScanData ToRotatingData(const RotatingScanner& scanner, const ScanSample& sample,
                                    int first_plane = 0);

/// An ordered scan of a sample from any scanner (point = origin + range * dir per beam).
OrderedScan SampleToOrderedScan(const SimScanner& scanner, const ScanSample& sample,
                                const std::string& source);

/// The noise-free ordered scan of the truth (every hit a return): what interpolation of a
/// perfect scan gives; used to place pairs and in tests.
OrderedScan TruthOrderedScan(const SimScanner& scanner, const ScanTruth& truth);

/// Cells [row0, row0 + rows) x [col0, col0 + cols) of TruthOrderedScan, cast again (the same
/// values), for a scan too large to hold (see point_pair.h ScanWindow).
OrderedScan TruthWindow(const Scene& scene, const SimScanner& scanner,
                        const Eigen::Isometry3d& T_world_scan, int row0, int col0, int rows,
                        int cols);

}  // namespace scancam::sim
