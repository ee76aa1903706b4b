// qScanCam: everything that differs between CloudCompare 2.11 and 2.12+ in one place,
// so that a later port touches only this file.
//   2.11: core namespace CCLib, interface IIDs edf.rd.CloudCompare.*/3.1 and /1.4
//   2.12+: CCCoreLib, cccorp.cloudcompare.*/1.5
#pragma once

#include <GenericProgressCallback.h>

namespace scancam_cc {
namespace cclib = ::CCLib;  // 2.12+: ::CCCoreLib
}  // namespace scancam_cc
