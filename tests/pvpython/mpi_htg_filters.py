"""mpi_htg_filters.py --plugin P --tmp DIR --reference JSON [--write-reference]:
ParaView's hyper-tree-grid filters on the HDT Voxelizer's distributed output.

Run serially (the reference) and by `pvbatch --mpi` on K ranks (mpi_test.sh).
The voxelizer's hyper tree grid of a Sphere (every rank: the whole root grid,
its own trees) goes through ParaView 5.11's HTG filters, directly and after
the ghost cells generator; what each gives, reduced over the ranks by
ParaView's data information with ghost cells removed (cell counts, bounds,
VoxelState ranges; point counts where pieces share no points), must equal
the serial run's:
  ghosts     HyperTreeGridGhostCellsGenerator
  depth      HyperTreeGridDepthLimiter at depth 3
  threshold  Threshold on VoxelState in [1, 2] (surface and inside)
  contour    Contour of VoxelState at 1.5 (after the ghost cells generator:
             without it the seams between ranks stay open, VTK's limitation)
  slice      Slice by the plane x = 0.1 (HyperTreeGridSlicer)
  clip       Clip by the plane x = 0.1 (HyperTreeGridClipper)
A hyper tree grid is counted by its visible leaves
(HyperTreeGridToUnstructuredGrid).
"""
import argparse
import json
import os

from paraview import simple

import hdt_testing as t


def info(proxy):
    """What ParaView's data information says of `proxy`'s output, reduced over
    ranks, ghost cells left out; for a hyper tree grid, of its visible leaves
    as an unstructured grid (HTG filters mask cells or limit the depth, they
    keep the vertices)."""
    proxy.UpdatePipeline()
    if proxy.GetDataInformation().GetDataSetTypeAsString() == "vtkHyperTreeGrid":
        leaves = simple.HyperTreeGridToUnstructuredGrid(Input=proxy)
        try:
            return info(leaves)
        finally:
            simple.Delete(leaves)
    own = simple.RemoveGhostInformation(Input=proxy)
    try:
        return counts(own)
    finally:
        simple.Delete(own)


def counts(proxy):
    proxy.UpdatePipeline()
    d = proxy.GetDataInformation()
    out = {"cells": d.GetNumberOfCells(), "points": d.GetNumberOfPoints(),
           "bounds": [round(b, 5) for b in d.GetBounds()] if d.GetNumberOfPoints() else None}
    a = proxy.CellData.GetArray("VoxelState")
    out["state_range"] = list(a.GetRange()) if a else None
    return out


def pipelines(vox):
    """name -> proxy for every filter of the test."""
    ghosts = simple.HyperTreeGridGhostCellsGenerator(Input=vox)
    out = {"htg": vox, "ghosts": ghosts}
    for name, src in (("", vox), ("ghosts+", ghosts)):
        out[name + "depth"] = simple.HyperTreeGridDepthLimiter(Input=src, SetDepth=3)
        out[name + "threshold"] = simple.Threshold(Input=src, Scalars=["CELLS", "VoxelState"], LowerThreshold=1.0,
                                                   UpperThreshold=2.0)
        out[name + "contour"] = simple.Contour(Input=src, ContourBy=["CELLS", "VoxelState"], Isosurfaces=[1.5])
        sl = simple.Slice(Input=src)
        sl.SliceType = "Plane"
        sl.SliceType.Origin = [0.1, 0.0, 0.0]
        sl.SliceType.Normal = [1.0, 0.0, 0.0]
        out[name + "slice"] = sl
        clip = simple.Clip(Input=src)
        clip.ClipType = "Plane"
        clip.ClipType.Origin = [0.1, 0.0, 0.0]
        clip.ClipType.Normal = [1.0, 0.0, 0.0]
        out[name + "clip"] = clip
    return out


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plugin", required=True)
    parser.add_argument("--tmp", required=True)
    parser.add_argument("--reference", required=True)
    parser.add_argument("--write-reference", action="store_true")
    args = parser.parse_args()
    ranks = simple.servermanager.ActiveConnection.GetNumberOfDataPartitions()
    t.load_plugin(args.plugin, globals())
    sphere = simple.Sphere(ThetaResolution=48, PhiResolution=32)
    vox = HDTVoxelizer(Input=sphere, Resolution=64, RootGridSize=4, LeafGridSize=8, Backend="CPU", MaxDepth=-1)
    result = {}
    for name, proxy in pipelines(vox).items():
        try:
            result[name] = info(proxy)
        except Exception as e:  # a filter ParaView cannot run here
            result[name] = {"error": str(e)}
        print("%d ranks: %-18s %s" % (ranks, name, result[name]), flush=True)
    if args.write_reference:
        json.dump(result, open(args.reference, "w"))
        return
    ref = json.load(open(args.reference))
    for name, got in result.items():
        want = ref[name]
        if name == "contour":
            # Without ghost cells VTK's HTG contour cannot close the seams
            # between ranks (it needs the neighbours' cells): documented in the
            # README, not compared.
            continue
        if name.endswith("contour") or name.endswith("slice"):
            # Polydata pieces each hold their own copy of the points on a seam.
            got, want = dict(got, points=None), dict(want, points=None)
        t.check_equal(got, want, "%s on %d ranks" % (name, ranks))
    if t._failures:
        t.finish()
    print("all checks passed")


if __name__ == "__main__":
    main()
