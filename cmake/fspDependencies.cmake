# The packages the installed fsp libraries (fsp::common, fsp::frontend, fsp::backend, fsp::pipeline)
# are built on, listed once: the top-level CMakeLists.txt finds them with find_package(... REQUIRED),
# the installed fspConfig.cmake with find_dependency. The includer defines
# fsp_dependency(NAME VERSION [ARGS...]) (VERSION "" for none).
fsp_dependency(Eigen3 3.4 NO_MODULE)
fsp_dependency(OpenCV 4 COMPONENTS core imgproc imgcodecs videoio calib3d features2d video)
fsp_dependency(Ceres 2.1)
fsp_dependency(apriltag "")
fsp_dependency(yaml-cpp "")
fsp_dependency(nlohmann_json 3)
fsp_dependency(Threads "")
