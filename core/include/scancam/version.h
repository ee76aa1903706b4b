// ScanCam version.
#pragma once
#define SCANCAM_VERSION_STRING "0.1.0"
