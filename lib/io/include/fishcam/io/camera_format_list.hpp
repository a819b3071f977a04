// The camera file formats: one line each, in detection order (of two formats that
// are equally sure of a file, the first wins). From this list come the
// CameraFormat enum, the format table (lib/io/src/formats/table.cpp), the fuzz
// harnesses (tests/fuzz/CMakeLists.txt, scripts/fuzz.sh) and the round-trip tests.
//
// Adding a format NAME: lib/io/src/formats/NAME.cpp defining `const FormatSpec
// NAME_format` (name, detection score, reader, writer, the models it holds), its
// line here, its section in docs/formats.md.
#pragma once

#define FISHCAM_CAMERA_FORMATS(X) \
  X(woodscape)                    \
  X(mrcal)                        \
  X(opencv)                       \
  X(fishcam)                      \
  X(kalibr)                       \
  X(basalt)                       \
  X(colmap)                       \
  X(ros)                          \
  X(camodocal)                    \
  X(orbslam3)                     \
  X(boofcv)                       \
  X(ocamcalib)
