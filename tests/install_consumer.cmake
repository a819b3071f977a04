# Installs the build tree into WORK_DIR/prefix, then configures, builds and runs
# tests/consumer against it with find_package(fishcam).
file(REMOVE_RECURSE ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGV} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "failed (${rc}): ${ARGV}\n${out}\n${err}")
  endif()
  message(STATUS "${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} -S ${CONSUMER_DIR} -B ${WORK_DIR}/build -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
    -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)

# The core layer alone: nothing but Eigen and fishcam_core on its compile and link lines.
run(${CMAKE_COMMAND} -S ${CONSUMER_DIR}/../consumer_core -B ${WORK_DIR}/build_core -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix
    -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build_core)
run(${WORK_DIR}/build_core/consumer_core)
file(READ ${WORK_DIR}/build_core/compile_commands.json core_compile)
file(READ ${WORK_DIR}/build_core/CMakeFiles/consumer_core.dir/link.txt core_link)
foreach(forbidden opencv ceres yaml pugixml nlohmann fishcam_io fishcam_fit fishcam_augment fishcam_eval)
  string(TOLOWER "${core_compile}${core_link}" core_lines)
  if(core_lines MATCHES "${forbidden}")
    message(FATAL_ERROR "a core-only consumer has ${forbidden} on its compile or link line:\n${core_compile}\n${core_link}")
  endif()
endforeach()
if(NOT core_link MATCHES "fishcam_core")
  message(FATAL_ERROR "the core consumer does not link fishcam_core: ${core_link}")
endif()

# A core-only build (-DFISHCAM_CORE_ONLY=ON) of the same sources: it looks for Eigen and
# libmrcal only, installs fishcam_core alone, and the core consumer builds against it.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/core_only -DFISHCAM_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release)
file(READ ${WORK_DIR}/core_only/CMakeCache.txt core_only_cache)
foreach(package OpenCV Ceres yaml-cpp pugixml nlohmann_json CLI11 GTest pybind11)
  if(core_only_cache MATCHES "\n${package}_DIR:")
    message(FATAL_ERROR "a core-only configure looked for ${package}")
  endif()
endforeach()
run(${CMAKE_COMMAND} --build ${WORK_DIR}/core_only)
run(${CMAKE_COMMAND} --install ${WORK_DIR}/core_only --prefix ${WORK_DIR}/core_prefix)
file(GLOB core_only_libraries ${WORK_DIR}/core_prefix/lib*/libfishcam_*.so)
list(LENGTH core_only_libraries core_only_count)
if(NOT core_only_count EQUAL 1)
  message(FATAL_ERROR "a core-only install holds ${core_only_count} fishcam libraries: ${core_only_libraries}")
endif()
run(${CMAKE_COMMAND} -S ${CONSUMER_DIR}/../consumer_core -B ${WORK_DIR}/build_core_only
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/core_prefix -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build_core_only)
run(${WORK_DIR}/build_core_only/consumer_core)
if(NOT EXISTS ${WORK_DIR}/prefix/bin/fishcam)
  message(FATAL_ERROR "the fishcam program was not installed")
endif()
run(${WORK_DIR}/prefix/bin/fishcam info ${WORK_DIR}/prefix/share/fishcam/woodscape_front.json --json)

# The Python package from the installed prefix (not the build tree), and the
# install folder is where /usr/bin/python3 looks when the prefix is /usr/local.
if(PYTHON_EXECUTABLE)
  execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=PYTHONPATH PYTHONPATH=${WORK_DIR}/prefix/${PYTHON_INSTALL_DIR}
                          ${PYTHON_EXECUTABLE} -c
                          "import fishcam, os; assert fishcam.__file__.startswith('${WORK_DIR}/prefix'), fishcam.__file__; c = fishcam.Camera.read('${WORK_DIR}/prefix/share/fishcam/woodscape_front.json'); print(c, fishcam.ViewpointWarp(c).float_kernel)"
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the installed Python package does not import: ${out}\n${err}")
  endif()
  message(STATUS "${out}")
  run(${PYTHON_EXECUTABLE} -c "import sys; d = '/usr/local/${PYTHON_INSTALL_DIR}'; assert d in sys.path, d + ' not in ' + str(sys.path)")
endif()
