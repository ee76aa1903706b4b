// qScanCam: everything that differs between CloudCompare 2.11 and 2.12+ in one place,
// so that a later port touches only this file.
//   2.11: core namespace CCLib, interface IIDs edf.rd.CloudCompare.*/3.1 and /1.4
//         (declared by ccStdPluginInterface.h itself; the plugin only names its own IID)
//   2.12+: CCCoreLib, cccorp.cloudcompare.*/1.5
// Never define CC_GL_WINDOW_USE_QWINDOW: Debian's ccGLWindow derives from QOpenGLWidget.
#pragma once

#include <GenericProgressCallback.h>
#include <ScalarField.h>

class ccGLWindow;  // 2.12+: ccGLWindowInterface (the picking modes moved there)

namespace scancam::plugin {
namespace cclib = ::CCLib;  // 2.12+: ::CCCoreLib

using GenericProgressCallback = cclib::GenericProgressCallback;
using ScalarField = cclib::ScalarField;

/// Registers `listener` with CloudCompare's picking hub for single points in the active 3D view
/// (not exclusive; starts picking). A template so that this header needs no GL header: the
/// picking mode is looked up when the caller (which includes ccPickingHub.h) instantiates it.
template <typename Hub, typename Listener, typename GlWindow = ccGLWindow>
bool AddPointPickingListener(Hub& hub, Listener* listener) {
  return hub.addListener(listener, /*exclusive=*/false, /*autoStartPicking=*/true,
                         GlWindow::POINT_PICKING);
}
}  // namespace scancam::plugin
