set(GRAPHVIZ_GRAPH_NAME "fishcam_layers")
set(GRAPHVIZ_IGNORE_TARGETS "^test_" "^fuzz_" "GTest" "gtest" "gmock" "^fishcam_python" "^fishcam_cli" "benchmark" "pybind11" "^Python" "CLI11" "^opencv_(imgcodecs|calib3d|flann|features2d|dnn|videoio|highgui|ml|objdetect|photo|stitching|video|gapi)" "gflags" "glog" "Threads" "OpenMP" "libatlas" "libblas" "libf77blas" "liblapack" "pthread" "libmrcal" "pugixml::shared" "^/usr/" "^-")
set(GRAPHVIZ_GENERATE_PER_TARGET FALSE)
set(GRAPHVIZ_GENERATE_DEPENDERS FALSE)
