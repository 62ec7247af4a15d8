"""check_image.py PNG: exits 1 unless the render shows both VoxelState colours
of scripts/render_demo.py (surface blue, inside orange) over a white
background. Run by render_demo_test.sh with pvbatch (no rendering needed)."""
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

reader = vtkPNGReader()
reader.SetFileName(sys.argv[1])
reader.Update()
image = reader.GetOutput()
w, h, _ = image.GetDimensions()
rgb = vtk_to_numpy(image.GetPointData().GetScalars())[:, :3].astype(int)
if w * h == 0:
    sys.exit("check_image: cannot read %s" % sys.argv[1])
r, g, b = rgb[:, 0], rgb[:, 1], rgb[:, 2]
blue = int(((b > r + 30) & (b > g)).sum())    # surface voxels, shaded
orange = int(((r > b + 60) & (g > b)).sum())  # inside voxels on the cut
print("check_image: %dx%d, %d bluish and %d orange pixels" % (w, h, blue, orange))
if blue < 0.02 * w * h or orange < 0.002 * w * h:
    sys.exit("check_image: the render does not show both surface and inside voxels")
