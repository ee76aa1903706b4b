#include "scancam/solve/calibration_json.h"

#include <cmath>
#include <cstddef>

#include "scancam/io/json_util.h"

namespace scancam::solve {

nlohmann::json CalibrationToJson(const Calibration& c, const nlohmann::json& inputs) {
  nlohmann::json j;
  j["T_cam_scan"] = io::PoseToJson(c.T_cam_scan);
  j["convention"] =
      "T_cam_scan maps scanner-frame points into the camera frame (X_cam = R X_scan + t, "
      "metres); camera frame = OpenCV (x right, y down, z forward); rotation_rpy_deg: R = "
      "Rz(yaw) Ry(pitch) Rx(roll)";
  j["rotation_rpy_deg"] = io::Vector3ToJson(c.rotation_rpy_deg);
  j["translation_m"] = io::Vector3ToJson(c.T_cam_scan.translation());
  j["method"] = c.method;
  j["refined"] = c.refined;
  j["weighted"] = c.weighted;
  if (c.refined) {
    j["variance_factor"] = c.variance_factor;
    j["reduced_chi_square"] = c.reduced_chi_square;
    j["noise_prior_dof"] = c.noise_prior_dof;
  }
  j["pair_count"] = c.pair_count;
  j["inlier_count"] = c.inlier_count;
  j["errors"] = {{"reprojection_px", {{"mean", c.mean_px}, {"std", c.std_px}, {"max", c.max_px}}},
                 {"angular_deg", {{"mean", c.mean_deg}, {"std", c.std_deg}, {"max", c.max_deg}}}};
  if (c.has_covariance) {
    j["std"] = {{"rotation_rpy_deg", io::Vector3ToJson(c.std_rpy_deg)},
                {"rotation_std_deg_cam_xyz", io::Vector3ToJson(c.std_rot_cam_deg)},
                {"translation_m", io::Vector3ToJson(c.std_t_m)}};
    j["rotation_std_deg_cam_xyz"] = io::Vector3ToJson(c.std_rot_cam_deg);
    nlohmann::json cov = nlohmann::json::array();
    for (int r = 0; r < 6; ++r) {
      nlohmann::json row = nlohmann::json::array();
      for (int k = 0; k < 6; ++k) row.push_back(c.covariance(r, k));
      cov.push_back(row);
    }
    j["covariance_rotvec_rad_t_m"] = cov;
  }
  if (c.geometry.distance_max_m > 0) {
    j["geometry"] = {{"image_rows_span_fraction", c.geometry.image_rows_fraction},
                     {"image_cols_span_fraction", c.geometry.image_cols_fraction},
                     {"distance_min_m", c.geometry.distance_min_m},
                     {"distance_max_m", c.geometry.distance_max_m}};
  }
  const bool several = !c.scenes.empty();
  nlohmann::json pairs = nlohmann::json::array();
  for (const auto& p : c.pairs) {
    nlohmann::json q;
    q["index"] = p.index + 1;
    if (several) q["scene"] = p.scene + 1;
    if (p.line) q["line"] = p.line;
    if (!p.label.empty()) q["label"] = p.label;
    q["image_px"] = {p.image_px.x(), p.image_px.y()};
    if (std::isfinite(p.scan_row)) q["scan_cell"] = {p.scan_row, p.scan_col};
    q["p_scan_m"] = io::Vector3ToJson(p.p_scan);
    q["inlier"] = p.inlier;
    q["error_deg"] = p.error_deg;
    q["threshold_deg"] = p.threshold_deg;
    if (std::isfinite(p.error_px)) q["error_px"] = p.error_px;
    if (p.reprojected_px) q["reprojected_px"] = {p.reprojected_px->x(), p.reprojected_px->y()};
    pairs.push_back(q);
  }
  j["pairs"] = pairs;
  nlohmann::json sug = nlohmann::json::array();
  for (const auto& g : c.suggestions) {
    nlohmann::json q = {
        {"image_px", {g.image_px.x(), g.image_px.y()}},
        {"scan_cell", {g.scan_row, g.scan_col}},
        {"p_scan_m", io::Vector3ToJson(g.p_scan)},
        {"predicted_std_rotation_rpy_deg", io::Vector3ToJson(g.predicted_std_rpy_deg)},
        {"predicted_rotation_std_deg_cam_xyz", io::Vector3ToJson(g.predicted_std_rot_cam_deg)},
        {"predicted_std_translation_m", io::Vector3ToJson(g.predicted_std_t_m)},
        {"reason", g.reason}};
    if (several) q["scene"] = g.scene + 1;
    sug.push_back(q);
  }
  j["suggested_picks"] = sug;
  if (several) {
    nlohmann::json sc = nlohmann::json::array();
    for (std::size_t k = 0; k < c.scenes.size(); ++k) {
      const SceneResult& r = c.scenes[k];
      nlohmann::json q = {{"scene", k + 1},
                          {"pairs", r.source},
                          {"pair_count", r.pair_count},
                          {"solved_alone", r.solved}};
      if (!r.error.empty()) q["error"] = r.error;
      if (r.solved) {
        q["alone"] = {{"T_cam_scan", io::PoseToJson(r.T_cam_scan)},
                      {"inlier_count", r.inlier_count},
                      {"rotation_std_deg_cam_xyz", io::Vector3ToJson(r.std_rot_cam_deg)},
                      {"std_translation_m", io::Vector3ToJson(r.std_t_m)}};
        q["vs_joint"] = {
            {"rotation_diff_deg_cam_xyz", io::Vector3ToJson(r.rotation_diff_cam_deg)},
            {"translation_diff_m", io::Vector3ToJson(r.translation_diff_m)},
            {"rotation_diff_sigma", io::Vector3ToJson(r.rotation_diff_sigma)},
            {"translation_diff_sigma", io::Vector3ToJson(r.translation_diff_sigma)},
            {"mahalanobis", r.mahalanobis},
            {"convention",
             "R_alone = exp(d) R_joint, d in the camera frame (deg); translation_diff = t_alone - "
             "t_joint; sigma = diff / std of the difference (covariance C_alone - C_joint)"}};
      }
      sc.push_back(q);
    }
    j["scenes"] = sc;
  }
  j["warnings"] = c.warnings;
  if (!inputs.is_null()) j["inputs"] = inputs;
  return j;
}

}  // namespace scancam::solve
