"""GUI smoke test, run inside the ParaView application:
  paraview --script=test_gui.py --exit      (ctest sets HDT_PLUGIN and HDT_TMP)
Loads the plugin as Tools > Manage Plugins would, applies the HDT Voxelizer to a
sphere with every property at its default, shows it in the GUI's render view
and takes a screenshot: VoxelState must be shown with the plugin's categorical
colour map (Outside, Inside, Surface named, fixed colours), and every coloured
pixel must be one of those colours (no continuous map). Then HDT To Image
sliced through the centre must show all three. Saves the volume as .hdt and
opens the file through the reader factory (File > Open). Prints
"gui_smoke: ok" when all of that worked; ctest looks for that line and for no
error output."""
import os

import numpy as np
from paraview.simple import *  # noqa: F401,F403
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

plugin, tmp = os.environ["HDT_PLUGIN"], os.environ["HDT_TMP"]
os.makedirs(tmp, exist_ok=True)
LoadPlugin(plugin, remote=False, ns=globals())

COLOURS = {"Outside": (0.75, 0.75, 0.75), "Inside": (0.97, 0.60, 0.20), "Surface": (0.40, 0.62, 0.85)}
problems = []


def named_colour_fractions(png, background):
    """Per named colour, the fraction of the non-background pixels of that hue
    (shading scales a colour, so directions are compared)."""
    reader = vtkPNGReader()
    reader.SetFileName(png)
    reader.Update()
    rgb = vtk_to_numpy(reader.GetOutput().GetPointData().GetScalars())[:, :3].astype(float) / 255.0
    rgb = rgb[np.abs(rgb - np.array(background)).sum(axis=1) > 0.05]
    norm = np.linalg.norm(rgb, axis=1) + 1e-9
    out = {}
    for name, ref in COLOURS.items():
        ref = np.array(ref)
        out[name] = float(((rgb @ ref / (norm * np.linalg.norm(ref)) > 0.995) & (norm > 0.25)).mean()) if len(rgb) else 0.0
    return out


sphere = Sphere(ThetaResolution=32, PhiResolution=32)
vox = HDTVoxelizer(Input=sphere)  # every property at its default, as after Apply
view = GetActiveViewOrCreate("RenderView")
view.OrientationAxesVisibility = 0
# What Apply does (pqApplyBehavior::showData): each output port shown in its
# preferred view. The XML's hints draw port 0 (the hyper tree grid) as its
# outline and port 1, the voxel surface, as a surface.
controller = servermanager.vtkSMParaViewPipelineControllerWithRendering()
for port in range(vox.GetNumberOfOutputPorts()):
    controller.ShowInPreferredView(vox.SMProxy, port, view.SMProxy)
Render(view)
cells = vox.GetDataInformation().GetNumberOfCells()
grid_display = GetDisplayProperties(OutputPort(vox, 0), view)
shown = [grid_display.Representation if grid_display.Visibility else "hidden",
         GetDisplayProperties(OutputPort(vox, 1), view).Representation]
if shown[0] not in ("Outline", "hidden") or shown[1] != "Surface":
    problems.append("after Apply, ports shown as %s: want the grid's outline and the voxel surface" % shown)
display = GetDisplayProperties(OutputPort(vox, 1), view)
lut = GetColorTransferFunction("VoxelState")
if list(display.ColorArrayName) != ["CELLS", "VoxelState"]:
    problems.append("not coloured by VoxelState: %s" % list(display.ColorArrayName))
if lut.InterpretValuesAsCategories != 1 or list(lut.Annotations) != ["0", "Outside", "1", "Inside", "2", "Surface"]:
    problems.append("VoxelState's colour map is not the categorical, named one")
background = list(view.Background)
png = os.path.join(tmp, "gui-defaults.png")
SaveScreenshot(png, view, ImageResolution=[400, 300])
fractions = named_colour_fractions(png, background)
# A closed solid's outer faces all belong to Surface voxels: the picture is the
# Surface colour, not the grey of Outside cells.
if fractions["Surface"] < 0.9:
    problems.append("after Apply, not the voxel surface in the Surface colour: %s" % fractions)

Hide(OutputPort(vox, 0), view)
Hide(OutputPort(vox, 1), view)
image = HDTToImage(Input=vox, Level=2)
slice_display = Show(image, view)
slice_display.SetRepresentationType("Slice")
ColorBy(slice_display, ("POINTS", "VoxelState"))
view.CameraPosition = [0, 0, 3]
view.CameraFocalPoint = [0, 0, 0]
view.CameraViewUp = [0, 1, 0]
ResetCamera(view)
png = os.path.join(tmp, "gui-image-slice.png")
SaveScreenshot(png, view, ImageResolution=[400, 300])
slice_fractions = named_colour_fractions(png, background)
if not all(f > 0.01 for f in slice_fractions.values()):
    problems.append("the HDT To Image slice does not show the three named colours: %s" % slice_fractions)
Hide(image, view)

path = os.path.join(tmp, "gui.hdt")
SaveData(path, proxy=vox)
reader = OpenDataFile(path)
Show(reader, view)
Render(view)
if not (cells > 0 and reader is not None and reader.GetXMLName() == "HDTReader"
        and reader.GetDataInformation().GetNumberOfCells() == cells):
    problems.append("voxelizer %d cells, reader %s" % (cells, reader))
if problems:
    print("gui_smoke: FAILED: " + "; ".join(problems))
else:
    print("gui_smoke: ok (%d cells; defaults %s; slice %s)" % (cells, fractions, slice_fractions))
