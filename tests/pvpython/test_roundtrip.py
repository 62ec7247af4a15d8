"""Save Data (.hdt, HDT Writer) then Open (HDT Reader) gives the same hyper tree grid.

A torus (Superquadric source, triangulated) is voxelized at N = 256 (R = 16,
L = 16: no octree level, h = 0), saved with SaveData as .hdt, compressed and
raw, and opened again with OpenDataFile. Checks:
  * the writer is the one the WriterFactory picks for .hdt and writes a file
    that starts with the .hdt magic; compressed files are smaller than raw ones;
  * reading gives the same grid: dimensions, coordinates, cells, leaves,
    levels, VoxelState, mask, leaf geometry and all field data (statistics,
    grid placement, phase times of the original build);
  * the reader's MaxDepth and MaskOutside give the same grids as the
    voxelizer's (they re-use the volume: the file is not read again);
  * re-saving the reader's output gives a file that reads back the same;
  * a hyper tree grid that does not come from the voxelizer or the reader is
    refused with a clear error and no file; so is an unwritable path.
"""
import os

from paraview.simple import *  # noqa: F401,F403 (pvpython idiom)
from paraview import servermanager

import hdt_testing as t

args = t.parse_args()
t.load_plugin(args.plugin, globals())

N, R, L = 256, 16, 16
torus = Superquadric(Toroidal=1, Thickness=0.3333, ThetaResolution=96, PhiResolution=48,
                     PhiRoundness=1.0, ThetaRoundness=1.0, Size=1.0)
mesh = Triangulate(Input=torus)
vox = HDTVoxelizer(Input=mesh, Resolution=N, RootGridSize=R, LeafGridSize=L, Backend="CPU")
original = t.fetch(vox)
t.check(original.GetNumberOfCells() > R ** 3, "the torus voxelizes (%d cells)" % original.GetNumberOfCells())
t.check(original.GetFieldData().GetArray("ActiveVoxels").GetTuple1(0) > 0, "the torus has surface voxels")


def same_grid(a, b, what):
    sa, sb = t.htg_summary(a), t.htg_summary(b)
    for key in sa:
        t.check(sa[key] == sb[key], "%s: same %s" % (what, key))
    t.check(t.leaf_geometry(a) == t.leaf_geometry(b), "%s: same leaf cells" % what)
    fa, fb = t.field_arrays(a), t.field_arrays(b)
    t.check_equal(sorted(fa), sorted(fb), "%s: same field arrays" % what)
    for name in fa:
        if name == "HDTVolumeId":  # names the process's volume object, not content: each output its own
            continue
        t.check(fa[name] == fb.get(name), "%s: field %s %r = %r" % (what, name, fa[name], fb.get(name)))


# --- save and open ---------------------------------------------------------------------
compressed = os.path.join(args.tmp, "torus.hdt")
raw = os.path.join(args.tmp, "torus-raw.hdt")
for path in (compressed, raw):
    if os.path.exists(path):
        os.remove(path)
SaveData(compressed, proxy=vox)
writer = CreateWriter(raw, vox)
t.check_equal(writer.GetXMLName(), "HDTWriter", "the WriterFactory picks the HDT Writer for .hdt")
writer.CompressLeaves = 0
writer.UpdatePipeline()
del writer
for path in (compressed, raw):
    t.check(os.path.isfile(path), "%s written" % os.path.basename(path))
    with open(path, "rb") as f:
        t.check_equal(f.read(4), b"HDT\0", "%s starts with the .hdt magic" % os.path.basename(path))
t.check(os.path.getsize(compressed) < os.path.getsize(raw),
        "zstd leaves are smaller: %d < %d bytes" % (os.path.getsize(compressed), os.path.getsize(raw)))

reader = OpenDataFile(compressed)
t.check_equal(reader.GetXMLName(), "HDTReader", "OpenDataFile picks the HDT Reader")
same_grid(t.fetch(reader), original, "compressed file")
reader_raw = HDTReader(FileName=raw)
same_grid(t.fetch(reader_raw), original, "raw file")

# --- display options: same grids as the voxelizer's -------------------------------------
for depth, mask in ((0, 1), (1, 1), (3, 0), (-1, 0)):
    vox.MaxDepth, vox.MaskOutside = depth, mask
    reader.MaxDepth, reader.MaskOutside = depth, mask
    same_grid(t.fetch(reader), t.fetch(vox), "MaxDepth %d MaskOutside %d" % (depth, mask))
vox.MaxDepth, vox.MaskOutside = -1, 1
reader.MaxDepth, reader.MaskOutside = -1, 1

# --- the reader's output saves too ------------------------------------------------------
again = os.path.join(args.tmp, "torus-again.hdt")
SaveData(again, proxy=reader)
same_grid(t.fetch(HDTReader(FileName=again)), original, "re-saved reader output")

# --- refusals -----------------------------------------------------------------------------
# Errors go to stderr through VTK's output window; no exception in Python.
other = HyperTreeGridRandom()
refused = os.path.join(args.tmp, "random.hdt")
if os.path.exists(refused):
    os.remove(refused)
SaveData(refused, proxy=other)
t.check(not os.path.exists(refused), "a foreign hyper tree grid is refused: no file")

# A filter that moves the grid (it shares the cell arrays but not the coordinates).
mirror = HyperTreeGridAxisReflection(Input=vox)
refused_mirror = os.path.join(args.tmp, "mirrored.hdt")
if os.path.exists(refused_mirror):
    os.remove(refused_mirror)
SaveData(refused_mirror, proxy=mirror)
t.check(not os.path.exists(refused_mirror), "a reflected voxelizer output is refused: no file")

SaveData(os.path.join(args.tmp, "no-such-dir", "x.hdt"), proxy=vox)
t.check(not os.path.exists(os.path.join(args.tmp, "no-such-dir")), "unwritable path: nothing created")

t.finish()
