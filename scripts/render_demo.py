"""Renders an HDT volume with ParaView (pvbatch) and prints its statistics.

  pvbatch scripts/render_demo.py --hdt out/demo.hdt --png out/demo.png
  pvbatch scripts/render_demo.py --mesh dragon.ply --resolution 512 --png dragon.png

--hdt opens an .hdt file (written by `hdt-voxelize -o` or File > Save Data)
with the HDT Reader; --mesh reads a mesh with ParaView's readers and voxelizes
it with the HDT Voxelizer filter. Either way the voxel surface (the filter's
second output: the outer faces of the voxels, merged) is shown, coloured by
VoxelState. --cutaway shows the hyper tree grid instead (first output, outside
masked) with the half nearest to the camera clipped away (an axis-aligned cut,
which keeps a hyper tree grid) to show the inside voxels and the coarse cells
of the tree; it is much slower to draw (ParaView's own HTG surface).

The plugin is loaded from --plugin, else from PV_PLUGIN_PATH (ParaView loads
it at start-up), else from build*/lib/paraview-*/plugins/HDTVoxelizer/ under
the repository. Debian's ParaView renders through X: on a machine without a
display run it under `xvfb-run -a -s "-screen 0 1280x1024x24 -noreset"`
(-noreset: see scripts/test.sh).
"""
import argparse
import glob
import os
import sys
import time

from paraview import simple

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# VoxelState: categorical colours (outside never shows with the mask).
STATE_COLOURS = {0: (0.75, 0.75, 0.75), 1: (0.97, 0.60, 0.20), 2: (0.40, 0.62, 0.85)}
STATE_NAMES = {0: "outside", 1: "inside", 2: "surface"}


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--hdt", help=".hdt file to open with the HDT Reader")
    src.add_argument("--mesh", help="mesh file (STL, OBJ, PLY, ...) to voxelize in ParaView")
    p.add_argument("--resolution", type=int, default=512, help="--mesh: voxels along the longest side")
    p.add_argument("--leaf-size", type=int, default=8, help="--mesh: leaf grid size (8, 16, 32)")
    p.add_argument("--max-depth", type=int, default=-1, help="cut the trees at this depth (-1: full)")
    p.add_argument("--png", required=True, help="image to write")
    p.add_argument("--size", default="1600x1000", help="image size WxH")
    p.add_argument("--cutaway", action="store_true",
                   help="clip away the half nearest to the camera to show the inside")
    p.add_argument("--cut-axis", choices="xyz", help="--cutaway: the axis the cut crosses "
                   "(default: the one the camera mostly looks along)")
    p.add_argument("--edges", action="store_true", help="draw the cell edges")
    p.add_argument("--color-by", choices=("VoxelState", "Label"), default="VoxelState",
                   help="cell array to colour by: VoxelState, or Label for a labelled volume "
                   "(categorical, named after the parts by the plugin)")
    p.add_argument("--view", default="1,-1.6,0.9", help="view direction from the focal point, x,y,z")
    p.add_argument("--up", default="0,0,1", help="view up, x,y,z")
    p.add_argument("--plugin", help="path of HDTVoxelizer.so")
    return p.parse_args()


def load_plugin(path):
    if hasattr(simple, "HDTReader"):
        return  # already loaded (PV_PLUGIN_PATH)
    candidates = [path] if path else sorted(
        glob.glob(os.path.join(ROOT, "build*", "lib", "paraview-*", "plugins", "HDTVoxelizer",
                               "HDTVoxelizer.so")), key=os.path.getmtime, reverse=True)
    if not candidates or not os.path.isfile(candidates[0]):
        sys.exit("render_demo: the HDT plugin was not found; build it (-DHDT_BUILD_PARAVIEW=ON) "
                 "and pass --plugin PATH/HDTVoxelizer.so or set PV_PLUGIN_PATH")
    simple.LoadPlugin(candidates[0], remote=False, ns=vars(simple))


def field(info, name):
    """A field array's first value, from the data information (no data fetch)."""
    a = info.GetFieldDataInformation().GetArrayInformation(name)
    return None if a is None else a.GetComponentRange(0)[0]


def print_statistics(source, seconds):
    # The statistics travel with the surface too: fetch it, not the (larger) hyper tree grid.
    data = simple.servermanager.Fetch(source, idx=1)
    surface_quads = data.GetNumberOfCells()
    htg = source.GetDataInformation()  # port 0, summary only
    fd = data.GetFieldData()

    def value(name, default=None):
        a = fd.GetAbstractArray(name)
        if a is None:
            return default
        return a.GetValue(0) if a.IsA("vtkStringArray") else a.GetTuple(0)[0]

    n, r, l, h = (int(value(k, 0)) for k in ("Resolution", "RootGridSize", "LeafGridSize", "Height"))
    rows = [
        ("resolution", "%d^3" % n, "R %d, octree height %d, leaf grids %d^3" % (r, h, l)),
        ("triangles", "{:,}".format(int(value("Triangles", 0))), "closed" if value("ClosedMesh") else "open"),
        ("tree elements", "{:,}".format(int(value("TreeElements", 0))), ""),
        ("leaf grids", "{:,}".format(int(value("LeafGrids", 0))), ""),
        ("active voxels", "{:,}".format(int(value("ActiveVoxels", 0))), "surface"),
        ("inside voxels", "{:,}".format(int(value("InsideVoxels", 0))), ""),
        ("bits / active voxel", "%.2f" % value("PaperBitsPerActiveVoxel", 0), "topology, paper's 20-byte elements"),
        ("memory", "%.1f MiB" % ((value("TopologyBytes", 0) + value("LeafBytes", 0)) / 2 ** 20),
         "tree + leaf grids"),
        ("build time", "%.1f ms" % value("TimeTotal", 0), "backend %s" % value("Backend", "?")),
        ("hyper tree grid", "{:,} cells".format(htg.GetNumberOfCells()), "port 0"),
        ("HTG conversion", "%.1f ms" % value("TimeConversion", 0), ""),
        ("voxel surface", "{:,} quads".format(surface_quads), "port 1, what is drawn without --cutaway"),
        ("load + render", "%.1f s" % seconds, ""),
    ]
    for name, v, note in rows:
        print("%-20s %16s  %s" % (name, v, note))


def main():
    args = parse_args()
    load_plugin(args.plugin)
    t0 = time.time()

    if args.hdt:
        source = simple.HDTReader(FileName=os.path.abspath(args.hdt))
        source.MaxDepth = args.max_depth
        source.MaskOutside = 1
    else:
        mesh = simple.OpenDataFile(os.path.abspath(args.mesh))
        if mesh is None:
            sys.exit("render_demo: ParaView cannot read %s" % args.mesh)
        surface = simple.ExtractSurface(Input=mesh)
        source = simple.HDTVoxelizer(Input=surface, Resolution=args.resolution,
                                     LeafGridSize=args.leaf_size, MaxDepth=args.max_depth,
                                     MaskOutside=1)
    source.UpdatePipeline()
    info = source.GetDataInformation()
    if info.GetNumberOfCells() == 0:
        sys.exit("render_demo: nothing to render (see the error above)")

    width, height = (int(v) for v in args.size.lower().split("x"))
    view = simple.CreateView("RenderView")
    view.ViewSize = [width, height]
    view.OrientationAxesVisibility = 0
    view.Background = [1, 1, 1]
    if hasattr(view, "UseColorPaletteForBackground"):
        view.UseColorPaletteForBackground = 0
    # Voxel faces have only six normals: a key light from the upper left and a
    # weak fill keep the three visible face orientations apart.
    view.KeyLightElevation = 60
    view.KeyLightAzimuth = -30
    view.KeyLightIntensity = 0.85
    view.FillLightKFRatio = 5.0

    lut = simple.GetColorTransferFunction(args.color_by)
    if args.color_by == "VoxelState":
        lut.InterpretValuesAsCategories = 1
        lut.Annotations = sum(([str(s), STATE_NAMES[s]] for s in (1, 2)), [])
        lut.IndexedColors = sum((list(STATE_COLOURS[s]) for s in (1, 2)), [])

    def show(proxy):
        display = simple.Show(proxy, view)
        display.Representation = "Surface With Edges" if args.edges else "Surface"
        display.EdgeColor = [0.1, 0.1, 0.1]
        simple.ColorBy(display, ("CELLS", args.color_by))  # Label: the plugin names the colours
        if args.color_by == "VoxelState":
            display.LookupTable = lut
        display.Ambient = 0.15
        display.Diffuse = 0.9
        display.Specular = 0.15
        return display

    # Camera: from --view towards the centre, fitted to the whole voxel surface
    # (also when the cut-away shows only part of it), then a little closer.
    surface = simple.OutputPort(source, 1)  # port 0 is the hyper tree grid
    display = show(surface)
    b = info.GetBounds()
    centre = [(b[2 * i] + b[2 * i + 1]) / 2 for i in range(3)]
    direction = [float(v) for v in args.view.split(",")]
    camera = view.GetActiveCamera()
    camera.SetFocalPoint(centre)
    camera.SetPosition([c + d for c, d in zip(centre, direction)])
    camera.SetViewUp([float(v) for v in args.up.split(",")])
    simple.Render(view)
    simple.ResetCamera(view)
    camera.Zoom(1.5)

    if args.cutaway:
        # Cut away the half nearest to the camera, across --cut-axis. On a hyper tree grid ParaView's Clip masks the cells
        # beyond the plane and keeps a hyper tree grid, so the cut face shows
        # the inside voxels and the coarse (Full) cells of the tree.
        axis = "xyz".index(args.cut_axis) if args.cut_axis else \
            max(range(3), key=lambda i: abs(direction[i]))
        normal = [0.0, 0.0, 0.0]
        normal[axis] = 1.0 if direction[axis] < 0 else -1.0  # points away from the camera
        clip = simple.Clip(Input=source, Invert=0)
        clip.HyperTreeGridClipper = "Plane"  # the clip function for hyper tree grids
        clip.HyperTreeGridClipper.Origin = centre
        clip.HyperTreeGridClipper.Normal = normal
        simple.Hide(surface, view)
        display = show(clip)

    if args.color_by == "VoxelState":  # (a bar of many part names says little)
        display.SetScalarBarVisibility(view, True)
        bar = simple.GetScalarBar(lut, view)
        bar.Title = "VoxelState"
        bar.ComponentTitle = ""
        bar.TitleColor = bar.LabelColor = [0.1, 0.1, 0.1]

    os.makedirs(os.path.dirname(os.path.abspath(args.png)), exist_ok=True)
    simple.SaveScreenshot(args.png, view, ImageResolution=[width, height])
    print("wrote %s (%dx%d)" % (args.png, width, height))
    print_statistics(source, time.time() - t0)


if __name__ == "__main__":
    main()
