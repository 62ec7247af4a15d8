"""The Resolution list of the HDT Voxelizer offers the valid values only.

Resolution's domain (plugin/domains/vtkSMHDTResolutionDomain.h) follows Root
Grid Size R and Leaf Grid Size L. Checks, for every R the panel offers, some
R set from Python (3, 5, 12) and every L:
  * the offered values are exactly the N in 1..65536 that hdt::validateConfig
    accepts (N = R x 2^h x L), found by brute force over all N;
  * the list changes when R or L changes (before Apply, as in the panel);
  * for the small grids, the smallest and the largest offered values that are
    cheap to build do build (cells, no error), and half the smallest value,
    not offered, is refused (empty output).
"""
from paraview.simple import *  # noqa: F401,F403 (pvpython idiom)

import hdt_testing as t

args = t.parse_args()
t.load_plugin(args.plugin, globals())

MAX_N = 65536


def valid_by_brute_force(r, l):
    """Every N of 1..65536 with N = R * 2^h * L, h >= 0 (core/src/config.cpp's rule)."""
    out = []
    for n in range(1, MAX_N + 1):
        if n % (r * l) == 0:
            q = n // (r * l)
            if q & (q - 1) == 0:
                out.append(n)
    return out


sphere = Sphere(ThetaResolution=16, PhiResolution=16)
vox = HDTVoxelizer(Input=sphere, Backend="CPU")
domain = vox.GetProperty("Resolution").SMProperty.GetDomain("enum")
t.check_equal(domain.GetClassName(), "vtkSMHDTResolutionDomain", "Resolution's domain")


def offered():
    return [domain.GetEntryValue(i) for i in range(domain.GetNumberOfEntries())]


t.check_equal(offered(), valid_by_brute_force(16, 16), "defaults R = L = 16: 256 .. 65536")
panel_roots = [int(vox.GetProperty("RootGridSize").SMProperty.GetDomain("enum").GetEntryValue(i))
               for i in range(vox.GetProperty("RootGridSize").SMProperty.GetDomain("enum").GetNumberOfEntries())]
for r in panel_roots + [3, 5, 12]:
    for l in (8, 16, 32):
        vox.RootGridSize, vox.LeafGridSize = r, l
        t.check_equal(offered(), valid_by_brute_force(r, l), "R = %d, L = %d: offered = valid" % (r, l))


def cells_at(r, l, n):
    vox.RootGridSize, vox.LeafGridSize, vox.Resolution = r, l, n
    vox.UpdatePipeline()
    return vox.GetDataInformation().GetNumberOfCells()


for r, l in ((1, 8), (2, 16), (4, 8), (3, 8), (16, 8), (16, 16)):
    vox.RootGridSize, vox.LeafGridSize = r, l
    values = offered()
    cheap = [n for n in values if n <= 256]
    for n in sorted({cheap[0], cheap[-1]}):
        t.check(cells_at(r, l, n) > 0, "R = %d, L = %d, N = %d (offered) builds" % (r, l, n))
print("expect one error below: a Resolution the list does not offer")
t.check_equal(cells_at(4, 8, 16), 0, "R = 4, L = 8, N = 16 (not offered) is refused")
t.finish()
