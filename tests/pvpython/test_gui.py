"""GUI smoke test, run inside the ParaView application:
  paraview --script=test_gui.py --exit      (ctest sets HDT_PLUGIN and HDT_TMP)
Loads the plugin as Tools > Manage Plugins would, voxelizes a sphere, shows it
in the GUI's render view, saves it as .hdt and opens the file through the
reader factory (File > Open), and prints "gui_smoke: ok" when all of that
worked; ctest looks for that line and for no error output."""
import os

from paraview.simple import *  # noqa: F401,F403

plugin, tmp = os.environ["HDT_PLUGIN"], os.environ["HDT_TMP"]
os.makedirs(tmp, exist_ok=True)
LoadPlugin(plugin, remote=False, ns=globals())

sphere = Sphere(ThetaResolution=32, PhiResolution=32)
vox = HDTVoxelizer(Input=sphere, Resolution=128)
Show(vox)
Render()
cells = vox.GetDataInformation().GetNumberOfCells()
path = os.path.join(tmp, "gui.hdt")
SaveData(path, proxy=vox)
reader = OpenDataFile(path)
Show(reader)
Render()
SaveScreenshot(os.path.join(tmp, "gui.png"), ImageResolution=[400, 300])
if (cells > 0 and reader is not None and reader.GetXMLName() == "HDTReader"
        and reader.GetDataInformation().GetNumberOfCells() == cells):
    print("gui_smoke: ok (%d cells)" % cells)
else:
    print("gui_smoke: FAILED (voxelizer %d cells, reader %s)" % (cells, reader))
