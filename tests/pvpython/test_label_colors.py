"""Categorical Label colours named after the parts (plugin/hdt_label_colors.cxx),
in pvpython: a multiblock of three named spheres, HDT Voxelizer Label By
Block, its voxel surface coloured by Label. Checks that the colour map is
categorical (IndexedLookup) with the block names as annotations of labels
1, 2, 3, that the render shows three distinct colours, each the map's colour
of one label, over the pixels of that sphere (shading scales a colour, so
hues are compared), and that the grid port gets the same map; a user's name
for a label is kept when Label is chosen again.
"""
import os

import numpy as np
from paraview.simple import *  # noqa: F401,F403  (note: it shadows all, min, max with numpy_interface's)
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

import hdt_testing as t

args = t.parse_args()
t.load_plugin(args.plugin, globals())

NAMES = ["housing", "shaft", "cap"]
BLOCKS_SCRIPT = """
from vtkmodules.vtkFiltersSources import vtkSphereSource
from vtkmodules.vtkCommonDataModel import vtkCompositeDataSet
out = self.GetOutput()
out.SetNumberOfBlocks(3)
for b, (name, x) in enumerate(zip(%r, (-1.1, 0.0, 1.1))):
    s = vtkSphereSource()
    s.SetCenter(x, 0.0, 0.0)
    s.SetRadius(0.5)
    s.SetThetaResolution(32)
    s.SetPhiResolution(24)
    s.Update()
    out.SetBlock(b, s.GetOutput())
    out.GetMetaData(b).Set(vtkCompositeDataSet.NAME(), name)
""" % (NAMES,)


def hue_fractions(png, colours):
    """Per colour, the fraction of pixels of the same hue (any shading)."""
    reader = vtkPNGReader()
    reader.SetFileName(png)
    reader.Update()
    rgb = vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars())[:, :3].astype(float) / 255.0
    norm = np.linalg.norm(rgb, axis=1) + 1e-9
    out = []
    for ref in colours:
        ref = np.array(ref)
        cos = rgb @ ref / (norm * np.linalg.norm(ref))
        out.append(float(((cos > 0.995) & (norm > 0.25)).mean()))
    return out


blocks = ProgrammableSource()
blocks.OutputDataSetType = "vtkMultiblockDataSet"
blocks.Script = BLOCKS_SCRIPT
vox = HDTVoxelizer(Input=blocks, Resolution=128, RootGridSize=8, Backend="CPU", LabelBy="Block")
vox.UpdatePipeline()

view = CreateView("RenderView")
view.ViewSize = [600, 240]
view.OrientationAxesVisibility = 0
view.UseColorPaletteForBackground = 0
view.Background = [0.0, 0.0, 0.0]
surface = Show(OutputPort(vox, 1), view)
ColorBy(surface, ("CELLS", "Label"))
lut = GetColorTransferFunction("Label")
t.check_equal(lut.InterpretValuesAsCategories, 1, "Label's colour map is categorical (IndexedLookup)")
annotations = list(lut.Annotations)
t.check_equal(annotations, ["1", "housing", "2", "shaft", "3", "cap"], "the block names annotate labels 1, 2, 3")
colours = np.array(lut.IndexedColors).reshape(-1, 3)
t.check_equal(len(colours), 3, "one colour a label")
distinct = bool(np.all([np.linalg.norm(colours[i] - colours[j]) > 0.3 for i in range(3) for j in range(i + 1, 3)]))
t.check(distinct, "the three colours are distinct: %s" % colours.tolist())

view.CameraPosition = [0, 0, 6]
view.CameraFocalPoint = [0, 0, 0]
view.CameraViewUp = [0, 1, 0]
ResetCamera(view)
png = os.path.join(args.tmp, "labels.png")
SaveScreenshot(png, view, ImageResolution=[600, 240])
fractions = hue_fractions(png, colours)
t.check(bool(np.all([f > 0.01 for f in fractions])), "each label's colour is on screen: %s" % fractions)
# Each sphere in its own colour: the first quarter of the columns the spheres
# cover is the housing's, the last quarter the cap's.
reader = vtkPNGReader()
reader.SetFileName(png)
reader.Update()
image = vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars())[:, :3].reshape(240, 600, 3)
lit_columns = np.nonzero((image.astype(float) / 255.0).max(axis=(0, 2)) > 0.25)[0]
first, last = (int(lit_columns[0]), int(lit_columns[-1])) if len(lit_columns) else (0, 599)
quarter = (last - first) // 4
for name, columns, colour in (("housing", slice(first, first + quarter), colours[0]),
                              ("cap", slice(last - quarter, last + 1), colours[2])):
    part = image[:, columns].reshape(-1, 3).astype(float) / 255.0
    lit = part[np.linalg.norm(part, axis=1) > 0.25]
    cos = lit @ colour / (np.linalg.norm(lit, axis=1) * np.linalg.norm(colour) + 1e-9)
    t.check(len(lit) > 0 and float((cos > 0.995).mean()) > 0.9,
            "the %s's pixels have its colour (%d lit pixels)" % (name, len(lit)))

# A user's own name survives choosing Label again; the grid port shares the map.
lut.Annotations = ["1", "outer housing", "2", "shaft", "3", "cap"]
ColorBy(surface, ("CELLS", "VoxelState"))
ColorBy(surface, ("CELLS", "Label"))
t.check_equal(list(lut.Annotations)[:2], ["1", "outer housing"], "a renamed label keeps its name")
grid = Show(vox, view)
ColorBy(grid, ("CELLS", "Label"))
t.check_equal(grid.LookupTable, lut, "the grid port uses the same Label colour map")

# VoxelState's map is not touched by choosing Label (it keeps its 3 states).
t.check_equal(list(GetColorTransferFunction("VoxelState").Annotations),
              ["0", "Outside", "1", "Inside", "2", "Surface"], "VoxelState's annotations unchanged")

# Views torn down at interpreter exit under Xvfb raise GLXBadContext (exit
# code 1): close the view first, as test_display.py does.
Delete(view)
del view
t.finish()
