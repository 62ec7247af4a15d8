"""Display defaults of the plugin, in pvpython (issue 13):
  * a new HDT Voxelizer has the defaults LeafGridSize 16 (as hdt-voxelize),
    MaskOutside off, MaxDepth Auto (-2); the depth used is the field array
    DisplayDepth, and Auto is the full depth at Resolution <= 1024;
  * VoxelState gets the plugin's categorical colour map (named Outside,
    Inside, Surface) without any setup, and a render shows those colours:
    the voxelizer's grid (surface blue), and an HDT To Image slice through the
    solid (outside grey, inside orange, surface blue), pixel colours checked;
  * HDT To Image equals the hyper tree grid's voxels (whole grid, level 0) for
    the voxelizer and the reader, and refuses an image over its bound;
  * the HTG filters of the issue: what works on the output, through which route.
"""
import os

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

import hdt_testing as t

args = t.parse_args()
t.load_plugin(args.plugin, globals())

COLOURS = {"Outside": (0.75, 0.75, 0.75), "Inside": (0.97, 0.60, 0.20), "Surface": (0.40, 0.62, 0.85)}


def colour_fractions(png):
    """Fraction of pixels near each named colour (any shading: same hue, same
    ordering of channels, scaled by lighting)."""
    reader = vtkPNGReader()
    reader.SetFileName(png)
    reader.Update()
    rgb = vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars())[:, :3].astype(float) / 255.0
    out = {}
    for name, ref in COLOURS.items():
        ref = np.array(ref)
        # Lambert shading scales the colour: compare directions, and reject dark pixels.
        norm = np.linalg.norm(rgb, axis=1) + 1e-9
        cos = rgb @ ref / (norm * np.linalg.norm(ref))
        out[name] = float(((cos > 0.995) & (norm > 0.25)).mean())
    return out


# --- defaults ---------------------------------------------------------------------------
sphere = Sphere(ThetaResolution=48, PhiResolution=48, Radius=0.5)
vox = HDTVoxelizer(Input=sphere)
# (Enumerated properties read back as their text in Python.)
t.check_equal(vox.GetProperty("LeafGridSize").SMProperty.GetElement(0), 16, "default LeafGridSize is the CLI's 16")
t.check_equal(vox.MaskOutside, 0, "MaskOutside is off by default")
t.check_equal(vox.GetProperty("MaxDepth").SMProperty.GetElement(0), -2, "MaxDepth defaults to Auto (-2)")
vox.Backend = "CPU"
htg = t.fetch(vox)
t.check_equal(t.field_value(htg, "DisplayDepth"), t.field_value(htg, "FullDepth"),
              "Auto is the full depth at Resolution 256")
t.check_equal(t.field_value(htg, "FullDepth"), 4, "full depth at 256 = 16 x 2^0 x 16: log2(16)")
vox.MaxDepth = 1
t.check_equal(t.field_value(t.fetch(vox), "DisplayDepth"), 1, "DisplayDepth follows MaxDepth")
vox.MaxDepth = -2
# The rest at 128^3 (R = 8) to keep the test quick.
vox.RootGridSize, vox.Resolution = 8, 128

# --- categorical colours in a render --------------------------------------------------------
view = CreateView("RenderView")
view.ViewSize = [400, 300]
view.OrientationAxesVisibility = 0
display = Show(vox, view)  # the hyper tree grid (port 0): shown as its outline by default
t.check_equal(display.Representation, "Outline", "the grid port's default representation")
display.SetRepresentationType("Surface")  # this test looks at the grid's own surface
t.check_equal(list(display.ColorArrayName), ["CELLS", "VoxelState"], "coloured by VoxelState")
lut = GetColorTransferFunction("VoxelState")
t.check_equal(lut.InterpretValuesAsCategories, 1, "VoxelState's colour map is categorical")
t.check_equal(list(lut.Annotations), ["0", "Outside", "1", "Inside", "2", "Surface"],
              "the states are named")
# Mask off: the Surface representation of the grid shows its outer box (outside cells).
view.CameraPosition = [2, 1.5, 3]
view.CameraFocalPoint = [0, 0, 0]
ResetCamera(view)
png = os.path.join(args.tmp, "grid.png")
SaveScreenshot(png, view, ImageResolution=[400, 300])
fractions = colour_fractions(png)
t.check(fractions["Outside"] > 0.05, "the unmasked grid shows the Outside colour: %s" % fractions)
vox.MaskOutside = 1
SaveScreenshot(png, view, ImageResolution=[400, 300])
fractions = colour_fractions(png)
t.check(fractions["Surface"] > 0.05 and fractions["Outside"] < 0.01,
        "the masked grid shows the Surface colour only: %s" % fractions)
vox.MaskOutside = 0
Hide(vox, view)

# A slice of HDT To Image (blocks of 4^3 voxels, so that the surface ring is
# several pixels wide) through the centre: all three named colours.
image = HDTToImage(Input=vox, Level=2)
slice_display = Show(image, view)
slice_display.SetRepresentationType("Slice")
ColorBy(slice_display, ("POINTS", "VoxelState"))
view.CameraPosition = [0, 0, 3]
view.CameraViewUp = [0, 1, 0]
ResetCamera(view)
png = os.path.join(args.tmp, "image-slice.png")
SaveScreenshot(png, view, ImageResolution=[400, 300])
fractions = colour_fractions(png)
t.check(all(fractions[n] > 0.005 for n in COLOURS),
        "the image slice shows Outside, Inside and Surface colours: %s" % fractions)

# --- HDT To Image equals the grid's voxels ------------------------------------------------
vox.MaskOutside, vox.MaxDepth = 0, -1
image.Level = 0
image_data = t.fetch(image)
states = vtk_to_numpy(image_data.GetPointData().GetArray("VoxelState"))
t.check_equal(image_data.GetDimensions(), (128, 128, 128), "HDT To Image: N^3 points at level 0")
counts = t.voxel_counts(t.fetch(vox))
t.check_equal([int((states == s).sum()) for s in (0, 1, 2)], [counts.get(s, (0,))[0] for s in (0, 1, 2)],
              "HDT To Image has the grid's voxel counts per state")
path = os.path.join(args.tmp, "display.hdt")
SaveData(path, proxy=vox)
reader = HDTReader(FileName=path, MaskOutside=1)
# The reader's grid gets the same named colours (the colour map follows the array name).
Hide(image, view)
reader_display = Show(reader, view)
reader_display.SetRepresentationType("Surface")
t.check_equal(list(reader_display.ColorArrayName), ["CELLS", "VoxelState"], "reader output coloured by VoxelState")
ResetCamera(view)
png = os.path.join(args.tmp, "reader.png")
SaveScreenshot(png, view, ImageResolution=[400, 300])
fractions = colour_fractions(png)
t.check(fractions["Surface"] > 0.05 and fractions["Outside"] < 0.01,
        "the reader's masked grid shows the Surface colour: %s" % fractions)
Hide(reader, view)
from_reader = t.fetch(HDTToImage(Input=reader))
t.check(np.array_equal(vtk_to_numpy(from_reader.GetPointData().GetArray("VoxelState")), states),
        "HDT To Image of the reader's output equals the voxelizer's")
coarse = t.fetch(HDTToImage(Input=vox, Level=3))
t.check_equal(coarse.GetDimensions(), (16, 16, 16), "Level 3: blocks of 8^3 voxels")
refused = HDTToImage(Input=vox, MaxMegabytes=1.0)
t.check_equal(t.fetch(refused).GetNumberOfPoints(), 0, "an image over MaxMegabytes is refused")

# --- ParaView's HTG filters on the output (README: "Hyper tree grid filters") ------------
vox.MaskOutside, vox.MaxDepth = 0, -2
def cells(proxy):
    proxy.UpdatePipeline()
    return proxy.GetDataInformation().GetNumberOfCells()


# At 0.5 (outside | solid): the boundary of the solid. A masked grid has no
# outside values left to contour against, so the mask must be off for it.
contour = Contour(Input=vox, ContourBy=["CELLS", "VoxelState"], Isosurfaces=[0.5])
t.check(cells(contour) > 0, "HTG Contour on VoxelState at 0.5 (mask off, the default) has cells")
vox.MaskOutside = 1
t.check(cells(contour) == 0, "HTG Contour at 0.5 with Mask Outside on: no cells (the outside is hidden)")
vox.MaskOutside = 0
unstructured = HyperTreeGridToUnstructuredGrid(Input=vox)
point_data = CellDatatoPointData(Input=unstructured)
point_data.UpdatePipeline()
t.check(point_data.GetDataInformation().GetPointDataInformation().GetArrayInformation("VoxelState") is not None,
        "Cell Data to Point Data works after HyperTreeGrid To Unstructured Grid")
integrated = t.fetch(IntegrateVariables(Input=unstructured))
volume = integrated.GetCellData().GetArray("Volume").GetValue(0)
spacing = t.field_value(t.fetch(vox), "VoxelSize")
t.check(abs(volume - (128 * spacing) ** 3) < 1e-6 * volume,
        "Integrate Variables after HyperTreeGrid To Unstructured Grid: the grid's volume")
image_contour = Contour(Input=image, ContourBy=["POINTS", "VoxelState"], Isosurfaces=[0.5])
t.check(cells(image_contour) > 0, "Contour on HDT To Image has cells")

# Rendering views torn down at interpreter exit under Xvfb raise a GLX error
# (GLXBadContext) that turns a passing run into exit code 1: close them first.
Delete(view)
del view
t.finish()
