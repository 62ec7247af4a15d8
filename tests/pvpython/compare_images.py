"""compare_images.py A.png B.png: exits 1 unless the two pictures have the same
size and at most 0.1% of their pixels differ by more than 8 in a channel (the
compositor may round a shade differently), and the picture is not blank."""
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader


def load(path):
    r = vtkPNGReader()
    r.SetFileName(path)
    r.Update()
    img = r.GetOutput()
    return img.GetDimensions(), vtk_to_numpy(img.GetPointData().GetScalars())[:, :3].astype(int)


(da, a), (db, b) = load(sys.argv[1]), load(sys.argv[2])
if da != db or a.size == 0:
    sys.exit("compare_images: sizes differ: %s %s" % (da, db))
differ = int((np.abs(a - b).max(axis=1) > 8).sum())
drawn = int((a.min(axis=1) < 200).sum())
print("compare_images: %d of %d pixels differ, %d drawn" % (differ, len(a), drawn))
if differ > 0.001 * len(a) or drawn < 0.05 * len(a):
    sys.exit("compare_images: the pictures differ (or nothing was drawn)")
