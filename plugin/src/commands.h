// qScanCam: command-line keywords (CloudCompare -SILENT mode and the GUI's command line).
//
//   -SCANCAM_CALIB -CAMERA cam_file -PAIRS pairs.csv -OUT calib.json
//                  [-METHOD ransac|paper|epnp|upnp] [-IMAGE image_file]
//                  [-GRID_STEP deg] [-ORIGIN ZERO|BOX_CENTER]
//       Calibrates the camera against the LAST loaded cloud (the scan the pairs' scan_row /
//       scan_col refer to; pairs with x,y,z need none) and writes the calibration JSON
//       (solve/calibration_json.h CalibrationToJson). -IMAGE checks the image size against the
//       camera file. Prints the summary (T_cam_scan, errors, flagged pairs).
//
//   -SCANCAM_COLORIZE -CAMERA cam_file -IMAGE image_file -CALIB calib.json
//                     [-MASK mask_image] [-GRID_STEP deg] [-ORIGIN ZERO|BOX_CENTER]
//       Colours EVERY loaded cloud in place from the image (colour/colourise.h, with
//       occlusion): per-point RGB, and the scalar fields "ScanCam visibility" (1 out of view,
//       2 occluded, 3 coloured) and "ScanCam quality" (image px per metre of surface). The
//       original colours are kept in the cloud's metadata (restorable in the GUI). -CALIB
//       takes scancam's calib.json, any JSON with a 4x4 "T_cam_scan", or an OpenCalib
//       extrinsic file. With -AUTO_SAVE ON (CloudCompare's default) each coloured cloud is
//       saved like CloudCompare's own commands save theirs (beside the input file, name
//       suffix _SCANCAM_COLORIZED, the -C_EXPORT_FMT format, a timestamp unless -NO_TIMESTAMP)
//       and the file written is printed; with -AUTO_SAVE OFF nothing is written (save with
//       -SAVE_CLOUDS). -SCANCAM_CALIB changes no cloud: it writes only -OUT, and prints it.
//
//   -SCANCAM_REFINE -CAMERA cam_file -IMAGE image_file -INIT start.json -OUT refined.json
//                   [-PAIRS pairs.csv [-PAIRS_WEIGHT w] [-SIGMA_PX px] [-SIGMA_CELLS cells]
//                   [-SIGMA_POINT_M m]] [-MASK mask_image] [-PARAMS refine_options.json]
//                   [-GRID_STEP deg] [-ORIGIN ZERO|BOX_CENTER]
//       Dense refinement of T_cam_scan (refine/dense_refine.h) from -INIT (any calibration
//       JSON) against the LAST loaded cloud, as `scancam refine` does for one scene: -PAIRS
//       adds the picked pairs as a prior and a held-out check (its strength and noise model:
//       scancam refine's --pairs-weight, --sigma-px, --sigma-cells, --sigma-point-m, same
//       defaults and checks), -PARAMS reads the options file
//       the window's Refine options dialog saves. Writes -OUT (refine/refinement_report.h: the
//       calibrate schema plus "refinement"; a rejected refinement keeps the start and says
//       why), prints the verdict and figures; changes no cloud.
//
//   The scan grid: a cloud read from an ordered format (PTX) keeps CloudCompare's scan grid,
//   which is used as is (the scanner's frame). Other clouds are re-gridded about their
//   ccGBLSensor (if any), else about -ORIGIN (default ZERO: the cloud's (0,0,0); BOX_CENTER:
//   its bounding-box centre), with -GRID_STEP degrees per cell (default: estimated).
//
//   Example (headless; without an X display CloudCompare needs QT_QPA_PLATFORM=offscreen, it
//   aborts otherwise):
//     QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -AUTO_SAVE OFF -O scan.ptx
//         -SCANCAM_COLORIZE -CAMERA camera.txt -IMAGE image.png -CALIB calib.json
//         -C_EXPORT_FMT PLY -SAVE_CLOUDS
//   Any error (missing file, size mismatch, bad calibration) is printed and makes
//   CloudCompare exit with status 1.
#pragma once

class ccCommandLineInterface;

namespace scancam::plugin {

void RegisterCommands(ccCommandLineInterface* cmd);

}  // namespace scancam::plugin
