"""mpi_render.py --plugin P --out PNG: renders the HDT Voxelizer's voxel surface
of a Sphere (coloured by VoxelState) and a clip of its hyper tree grid, with a
fixed camera. mpi_test.sh runs it serially and on 4 ranks (pvbatch --mpi: the
ranks render their pieces, ParaView composites) and compares the pictures."""
import argparse

from paraview import simple

parser = argparse.ArgumentParser()
parser.add_argument("--plugin", required=True)
parser.add_argument("--out", required=True)
args = parser.parse_args()
simple.LoadPlugin(args.plugin, remote=False, ns=globals())

sphere = simple.Sphere(ThetaResolution=48, PhiResolution=32)
vox = HDTVoxelizer(Input=sphere, Resolution=64, RootGridSize=4, LeafGridSize=8, Backend="CPU", MaxDepth=-1)
view = simple.CreateView("RenderView")
view.ViewSize = [480, 360]
view.OrientationAxesVisibility = 0
view.Background = [1, 1, 1]
try:
    view.UseColorPaletteForBackground = 0
except AttributeError:
    pass
surface = simple.Show(simple.OutputPort(vox, 1), view)
simple.ColorBy(surface, ("CELLS", "VoxelState"))
surface.LookupTable = simple.GetColorTransferFunction("VoxelState")
surface.LookupTable.RescaleTransferFunction(0.0, 2.0)
view.CameraPosition = [1.6, 1.1, 2.2]
view.CameraFocalPoint = [0, 0, 0]
view.CameraViewUp = [0, 1, 0]
view.CameraParallelScale = 0.8
simple.Render(view)
simple.SaveScreenshot(args.out, view, ImageResolution=[480, 360])
print("mpi_render: wrote %s" % args.out)
