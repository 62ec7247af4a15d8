"""HDT Voxelizer in pvpython: output type, statistics, voxel counts, and
agreement with hdt-voxelize on the same mesh.

A Sphere source (64 x 64, triangles) is voxelized at N = 256 (R = 16, L = 8:
an octree of height 1 above the leaf grids). Checks:
  * the output is a vtkHyperTreeGrid with R^3 trees and cell array VoxelState;
  * the field data hold the statistics and they are consistent;
  * counted from the grid's leaves (VTK's own HTG-to-hexahedra filter), the
    surface voxels equal ActiveVoxels, the inside voxels InsideVoxels, every
    surface leaf is one voxel, and with MaskOutside off all N^3 voxels are
    covered exactly once;
  * the mesh's volume lies between the inside and the inside + surface voxels;
  * MaxDepth and MaskOutside behave (coarse grid of R^3 cells at depth 0;
    masked cells are the outside leaves);
  * with --cli: the same mesh, saved as PLY and voxelized by hdt-voxelize,
    gives the same statistics, and its .hdt file opened with the HDT Reader
    gives the very same hyper tree grid.
"""
import math
import os

from paraview.simple import *  # noqa: F401,F403 (pvpython idiom)

import hdt_testing as t

args = t.parse_args()
t.load_plugin(args.plugin, globals())

N, R, L = 256, 16, 8
sphere = Sphere(ThetaResolution=64, PhiResolution=64, Radius=0.5)
vox = HDTVoxelizer(Input=sphere, Resolution=N, RootGridSize=R, LeafGridSize=L, Backend="CPU",
                   MaskOutside=1, MaxDepth=-1)  # the masked grid at full depth (not the defaults)
htg = t.fetch(vox)

# --- type and layout ------------------------------------------------------------
t.check_equal(htg.GetClassName(), "vtkHyperTreeGrid", "output type")
t.check_equal(tuple(htg.GetDimensions()), (R + 1, R + 1, R + 1), "root grid points")
t.check_equal(htg.GetNumberOfNonEmptyTrees(), R ** 3, "trees")
t.check_equal(htg.GetBranchFactor(), 2, "branch factor")
t.check(htg.GetCellData().GetArray("VoxelState") is not None, "cell array VoxelState exists")
full_depth = 1 + int(math.log2(L))  # h = log2(N / (R L)) = 1
t.check_equal(htg.GetNumberOfLevels(), full_depth + 1, "levels (depths 0..h+log2 L)")

# --- the second output: the voxel surface ------------------------------------------
t.check_equal(vox.GetNumberOfOutputPorts(), 2, "output ports")
t.check_equal([vox.GetOutputPortName(i) for i in (0, 1)], ["Hyper Tree Grid", "Voxel Surface"],
              "output port names")
surface = servermanager.Fetch(vox, idx=1)
t.check_equal(surface.GetClassName(), "vtkPolyData", "port 1 type")
t.check(surface.GetNumberOfPolys() > 0 and surface.GetNumberOfPolys() == surface.GetNumberOfCells(),
        "port 1 holds quads only")
surface_states = surface.GetCellData().GetArray("VoxelState")
t.check(surface_states is not None and tuple(surface_states.GetRange()) == (2.0, 2.0),
        "a sphere's outer faces all bound surface voxels")
sb, hb = surface.GetBounds(), htg.GetBounds()
t.check(all(hb[2 * a] <= sb[2 * a] and sb[2 * a + 1] <= hb[2 * a + 1] for a in range(3)),
        "the surface lies inside the grid")
t.check(surface.GetFieldData().GetAbstractArray("ActiveVoxels") is not None,
        "the surface carries the build statistics")

# --- statistics ------------------------------------------------------------------
stats = t.field_arrays(htg)
for name in ("Resolution", "RootGridSize", "LeafGridSize", "Height", "TreeElements",
             "LeafGrids", "LeafVoxels", "ActiveVoxels", "InsideVoxels",
             "PaperBitsPerActiveVoxel", "TopologyBytes", "LeafBytes", "Triangles",
             "TimeTotal", "Backend", "VoxelSize", "Origin", "ClosedMesh"):
    t.check(name in stats, "field array %s present" % name)
t.check_equal(stats.get("Resolution"), N, "Resolution")
t.check_equal(stats.get("Height"), 1, "Height")
t.check_equal(stats.get("Backend"), "cpu", "Backend")
t.check_equal(stats.get("ClosedMesh"), 1, "a sphere is closed")
t.check_equal(stats.get("Triangles"), sphere.GetDataInformation().GetNumberOfCells(), "Triangles")
t.check_equal(stats.get("LeafVoxels"), stats.get("LeafGrids") * L ** 3, "LeafVoxels = LeafGrids L^3")
t.check_equal(stats.get("TopologyBytes"), 4 * stats.get("TreeElements"), "TopologyBytes")
t.check(abs(stats.get("PaperBitsPerActiveVoxel") -
            stats["TreeElements"] * 160.0 / stats["ActiveVoxels"]) < 1e-9,
        "PaperBitsPerActiveVoxel = elements * 20 bytes / active voxels")

# --- voxel counts from the leaves ------------------------------------------------------
counts = t.voxel_counts(htg)
surface_voxels, surface_leaves, surface_unit = counts.get(2, (0, 0, 0))
inside_voxels = counts.get(1, (0, 0, 0))[0]
t.check_equal(surface_voxels, stats["ActiveVoxels"], "surface voxels in the grid = ActiveVoxels")
t.check_equal(surface_unit, surface_leaves, "every surface leaf is a single voxel")
t.check_equal(inside_voxels, stats["InsideVoxels"], "inside voxels in the grid = InsideVoxels")
t.check(0 not in counts, "MaskOutside hides every outside leaf")
# The polyhedron's volume lies between the inside voxels and inside + surface.
from vtkmodules.vtkFiltersCore import vtkMassProperties  # noqa: E402

mass = vtkMassProperties()
mass.SetInputData(t.fetch(sphere))
mass.Update()
volume = mass.GetVolume() / stats["VoxelSize"] ** 3
t.check(inside_voxels <= volume <= inside_voxels + surface_voxels,
        "mesh volume %.0f voxels lies in [inside, inside + surface] = [%d, %d]"
        % (volume, inside_voxels, inside_voxels + surface_voxels))

vox.MaskOutside = 0
unmasked = t.fetch(vox)
t.check(unmasked.GetMask() is None or unmasked.GetMask().GetNumberOfTuples() == 0,
        "MaskOutside off: no mask")
all_counts = t.voxel_counts(unmasked)
t.check_equal(sum(v[0] for v in all_counts.values()), N ** 3, "unmasked leaves cover N^3 voxels")
t.check_equal(all_counts.get(2, (0,))[0], stats["ActiveVoxels"], "unmasked: same surface voxels")
vox.MaskOutside = 1

vox.MaxDepth = 0
coarse = t.fetch(vox)
t.check_equal(coarse.GetNumberOfCells(), R ** 3, "MaxDepth 0: one cell per root cell")
t.check_equal(coarse.GetNumberOfLevels(), 1, "MaxDepth 0: one level")
vox.MaxDepth = 2
mid = t.fetch(vox)
t.check_equal(mid.GetNumberOfLevels(), 3, "MaxDepth 2: three levels")
t.check(mid.GetNumberOfCells() < htg.GetNumberOfCells(), "MaxDepth 2: fewer cells than full depth")
vox.MaxDepth = -1

# --- the same mesh through the command-line tool ---------------------------------------
if args.cli:
    ply = os.path.join(args.tmp, "sphere.ply")
    hdt = os.path.join(args.tmp, "sphere-cli.hdt")
    SaveData(ply, proxy=sphere, FileType="Binary")
    cli = t.run_cli(args.cli, [ply, "--resolution", str(N), "--root-grid", str(R),
                               "--leaf-size", str(L), "--backend", "cpu", "-o", hdt])
    for key, name in (("active_voxels", "ActiveVoxels"), ("inside_voxels", "InsideVoxels"),
                      ("tree_elements", "TreeElements"), ("leaf_grids", "LeafGrids"),
                      ("triangles", "Triangles"), ("height", "Height")):
        t.check_equal(cli[key], stats[name], "hdt-voxelize %s = plugin %s" % (key, name))
    t.check_equal(tuple(cli["origin"]), stats["Origin"], "hdt-voxelize origin = plugin Origin")
    t.check_equal(cli["voxel_size"], stats["VoxelSize"], "hdt-voxelize voxel_size = plugin VoxelSize")

    reader = OpenDataFile(hdt)
    t.check(reader is not None and reader.GetXMLName() == "HDTReader",
            "OpenDataFile picks the HDT Reader for .hdt")
    reader.MaskOutside, reader.MaxDepth = 1, -1  # the voxelizer's settings above
    from_cli = t.fetch(reader)
    a, b = t.htg_summary(from_cli), t.htg_summary(htg)
    for key in a:
        t.check(a[key] == b[key], "CLI's .hdt in the reader = voxelizer output: %s" % key)
    t.check(t.leaf_geometry(from_cli) == t.leaf_geometry(htg),
            "CLI's .hdt in the reader = voxelizer output: leaf cells")
else:
    print("skip: no --cli, hdt-voxelize cross-check not run")

t.finish()
