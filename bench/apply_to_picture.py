"""Apply-to-first-picture in pvpython: what a ParaView user waits for after Apply.

  xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" pvpython bench/apply_to_picture.py \
      --mesh ../shared/meshes/stanford-dragon-100k.ply --resolution 2048 [--port 1]

Opens the mesh, applies the HDT Voxelizer (CPU backend, the filter's other
defaults), updates it as Apply does (every output port), shows one output port
in a 1280x800 render view with its default Surface representation coloured by
VoxelState and renders once. --port 1 (default) shows the Voxel Surface, what
Apply shows since the surface port exists; --port 0 the hyper tree grid, what
it showed before. Prints one JSON line: seconds per step and the peak resident
memory of the process (the builtin server runs in it).
"""
import argparse
import glob
import json
import os
import resource
import time

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--mesh", required=True)
    p.add_argument("--resolution", type=int, default=2048)
    p.add_argument("--port", type=int, default=1, help="1: voxel surface, 0: hyper tree grid")
    p.add_argument("--plugin", help="HDTVoxelizer.so (default: the newest build*/ one)")
    p.add_argument("--png", help="also save the picture here")
    args = p.parse_args()

    plugin = args.plugin or sorted(glob.glob(os.path.join(
        ROOT, "build*", "lib", "paraview-*", "plugins", "HDTVoxelizer", "HDTVoxelizer.so")),
        key=os.path.getmtime)[-1]
    simple.LoadPlugin(plugin, remote=False, ns=vars(simple))

    t0 = time.time()
    mesh = simple.OpenDataFile(os.path.abspath(args.mesh))
    mesh.UpdatePipeline()
    t_read = time.time()
    voxelizer = simple.HDTVoxelizer(Input=mesh, Resolution=args.resolution, Backend="CPU")
    voxelizer.UpdatePipeline()  # every output port, as Apply does
    t_update = time.time()

    view = simple.CreateView("RenderView")
    view.ViewSize = [1280, 800]
    display = simple.Show(simple.OutputPort(voxelizer, args.port), view)
    display.Representation = "Surface"
    simple.ColorBy(display, ("CELLS", "VoxelState"))
    simple.ResetCamera(view)
    simple.Render(view)
    t_render = time.time()
    if args.png:
        simple.SaveScreenshot(args.png, view, ImageResolution=[1280, 800])

    polygons = display.GetRepresentedDataInformation().GetNumberOfCells()
    print(json.dumps({
        "mesh": os.path.basename(args.mesh), "resolution": args.resolution, "port": args.port,
        "read_s": round(t_read - t0, 2), "filter_update_s": round(t_update - t_read, 2),
        "first_render_s": round(t_render - t_update, 2),
        "apply_to_picture_s": round(t_render - t_read, 2),
        "rendered_cells": polygons,
        "peak_rss_gb": round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20, 2)}))


if __name__ == "__main__":
    main()
