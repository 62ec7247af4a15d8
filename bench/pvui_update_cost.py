"""pvpython bench/pvui_update_cost.py PLUGIN MESH [RESOLUTION ...]

Update time of the HDT Voxelizer through ParaView's pipeline (the proxy's
UpdatePipeline: build + conversion + ParaView's copies of the output), with
Mask Outside off and on, the rest at the plugin's defaults (CPU backend,
Max Depth full so the grids compare). The build is done once per resolution
(the filter re-uses it when only the mask changes), so the two rows differ
only in what the mask costs. Also: how long an abort takes to stop a build
(the filter's AbortExecute set from a progress observer after 0.5 s).
Results: bench/results/pvui.md."""
import sys
import time

from paraview import servermanager
from paraview.simple import *  # noqa: F401,F403

plugin, mesh_path = sys.argv[1], sys.argv[2]
resolutions = [int(r) for r in sys.argv[3:]] or [1024]
LoadPlugin(plugin, remote=False, ns=globals())
mesh = OpenDataFile(mesh_path)
mesh.UpdatePipeline()
print("| Resolution | Mask Outside | update (s) | HTG cells |")
print("|---:|:---:|---:|---:|")
for n in resolutions:
    vox = HDTVoxelizer(Input=mesh, Resolution=n, Backend="CPU", MaxDepth=-1, MaskOutside=0)
    t0 = time.perf_counter()
    vox.UpdatePipeline()  # the build and a conversion without the mask
    print("| %d | off (with the build) | %.2f | %d |" % (n, time.perf_counter() - t0,
                                                        vox.GetDataInformation().GetNumberOfCells()))
    for mask in (1, 0):
        vox.MaskOutside = mask
        t0 = time.perf_counter()
        vox.UpdatePipeline()
        dt = time.perf_counter() - t0
        print("| %d | %s | %.2f | %d |" % (n, "on" if mask else "off", dt,
                                            vox.GetDataInformation().GetNumberOfCells()))
    Delete(vox)

# Abort: a progress observer sets AbortExecute 0.5 s into the build.
n = max(resolutions)
vox = HDTVoxelizer(Input=mesh, Resolution=n, Backend="CPU", MaxDepth=0)
algorithm = vox.GetClientSideObject()
start = [None]


def on_progress(obj, event):
    if start[0] is not None and time.perf_counter() - start[0] > 0.5:
        obj.SetAbortExecute(1)


algorithm.AddObserver("ProgressEvent", on_progress)
start[0] = time.perf_counter()
vox.UpdatePipeline()
print("abort requested at 0.5 s into a %d^3 build: the update returned after %.2f s, %d cells"
      % (n, time.perf_counter() - start[0], vox.GetDataInformation().GetNumberOfCells()))
