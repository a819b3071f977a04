#!/usr/bin/python3
# mrcal's reprojection map between two .cameramodel files, as float32 .npy:
#   mrcal_map.py SOURCE.cameramodel TARGET.cameramodel DISTANCE|none OUT.npy
# Used by `fishcam check-mrcal` and the tests (run with /usr/bin/python3, where
# Debian's python3-mrcal lives).
import sys

import mrcal
import numpy as np

if len(sys.argv) != 5:
    sys.exit("usage: mrcal_map.py SOURCE TARGET DISTANCE|none OUT.npy")
source = mrcal.cameramodel(sys.argv[1])
target = mrcal.cameramodel(sys.argv[2])
distance = None if sys.argv[3] == "none" else float(sys.argv[3])
mapxy = mrcal.image_transformation_map(source, target, distance=distance)
np.save(sys.argv[4], np.ascontiguousarray(mapxy, dtype=np.float32))
