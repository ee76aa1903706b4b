# Installs the core for find_package(ScanCam): the module libraries, the public headers and
# ScanCamConfig.cmake (+ version file) exporting ScanCam::core (every module) and ScanCam::<module>.
# Component "core": `cmake --install <build> --component core --prefix <dir>` installs only this.
include(CMakePackageConfigHelpers)
include(GNUInstallDirs)

set(SCANCAM_CMAKE_INSTALL_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/ScanCam)
set(_scancam_export_targets scancam_core scancam_opencv scancam_pcl)
foreach(m IN LISTS SCANCAM_CORE_MODULES)
  list(APPEND _scancam_export_targets scancam_${m})
endforeach()
# scancam_opencv / scancam_pcl: the wrappers around OpenCV's and PCL's variables (PCL only as a
# link dependency of the static module libraries: no installed header includes PCL).
set_target_properties(scancam_opencv PROPERTIES EXPORT_NAME opencv)
set_target_properties(scancam_pcl PROPERTIES EXPORT_NAME pcl)
install(TARGETS ${_scancam_export_targets} EXPORT ScanCamTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT core
        INCLUDES DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
install(DIRECTORY ${PROJECT_SOURCE_DIR}/core/include/scancam
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT core FILES_MATCHING PATTERN "*.h")
install(EXPORT ScanCamTargets NAMESPACE ScanCam:: DESTINATION ${SCANCAM_CMAKE_INSTALL_DIR}
        COMPONENT core)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/ScanCamConfig.cmake.in
                              ${PROJECT_BINARY_DIR}/ScanCamConfig.cmake
                              INSTALL_DESTINATION ${SCANCAM_CMAKE_INSTALL_DIR})
write_basic_package_version_file(${PROJECT_BINARY_DIR}/ScanCamConfigVersion.cmake
                                 COMPATIBILITY SameMinorVersion)
install(FILES ${PROJECT_BINARY_DIR}/ScanCamConfig.cmake
              ${PROJECT_BINARY_DIR}/ScanCamConfigVersion.cmake
        DESTINATION ${SCANCAM_CMAKE_INSTALL_DIR} COMPONENT core)
