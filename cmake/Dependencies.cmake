# Every dependency is a Debian bookworm package (scripts/install-deps.sh).
# Only the components the project uses are requested, to keep the build lean.
find_package(Eigen3 3.3 REQUIRED NO_MODULE)
find_package(Ceres REQUIRED)
find_package(OpenCV 4 REQUIRED COMPONENTS core imgproc imgcodecs calib3d ccalib)
find_package(OpenMP REQUIRED COMPONENTS CXX)
find_package(nlohmann_json 3 REQUIRED)
find_package(pugixml REQUIRED)  # the XML section of E57 files
find_package(opengv REQUIRED)
find_package(mrpt-obs REQUIRED)
find_package(mrpt-io REQUIRED)
find_package(mrpt-serialization REQUIRED)
# CObservationRotatingScan (and its fromVelodyne) lives in mrpt-maps in MRPT 2.5.
find_package(mrpt-maps REQUIRED)

# PCL's config is slow and noisy; ask only for what is used and wrap it in one target.
find_package(PCL 1.13 REQUIRED COMPONENTS common io surface sample_consensus)
add_library(scancam_pcl INTERFACE)
target_include_directories(scancam_pcl SYSTEM INTERFACE ${PCL_INCLUDE_DIRS})
target_link_libraries(scancam_pcl INTERFACE ${PCL_LIBRARIES})
target_compile_definitions(scancam_pcl INTERFACE ${PCL_DEFINITIONS})

add_library(scancam_opencv INTERFACE)
target_include_directories(scancam_opencv SYSTEM INTERFACE ${OpenCV_INCLUDE_DIRS})
target_link_libraries(scancam_opencv INTERFACE ${OpenCV_LIBS})

if(SCANCAM_BUILD_PLUGIN)
  find_package(Qt5 5.15 REQUIRED COMPONENTS Core Gui Widgets OpenGL Concurrent Test)
endif()
