"""Helpers shared by the pvpython tests of the HDT plugin (not a test itself).

Every test script takes the same arguments (tests/pvpython/CMakeLists.txt
passes them):
  --plugin PATH   the built plugin (HDTVoxelizer.so)
  --cli PATH      hdt-voxelize, for cross-checks (optional)
  --tmp DIR       a scratch directory of the test's own
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np
from paraview import servermanager
from paraview import simple
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkFiltersHyperTree import vtkHyperTreeGridToUnstructuredGrid

_failures = []


def parse_args():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plugin", required=True)
    parser.add_argument("--cli", default="")
    parser.add_argument("--tmp", required=True)
    args = parser.parse_args()
    os.makedirs(args.tmp, exist_ok=True)
    return args


def load_plugin(path, ns):
    # remote=False: pvpython runs the builtin session, client and server in one.
    simple.LoadPlugin(path, remote=False, ns=ns)


def check(condition, message):
    """Records a failure instead of stopping, so one run reports them all."""
    status = "ok  " if condition else "FAIL"
    print("%s %s" % (status, message), flush=True)
    if not condition:
        _failures.append(message)


def check_equal(actual, expected, message):
    check(actual == expected, "%s: %r (expected %r)" % (message, actual, expected))


def finish():
    if _failures:
        print("%d check(s) failed:" % len(_failures))
        for f in _failures:
            print("  " + f)
        sys.exit(1)
    print("all checks passed")
    sys.exit(0)


def fetch(proxy):
    proxy.UpdatePipeline()
    return servermanager.Fetch(proxy)


def field_value(data, name):
    array = data.GetFieldData().GetAbstractArray(name)
    if array is None:
        return None
    if array.IsA("vtkStringArray"):
        return array.GetValue(0)
    value = array.GetTuple(0)
    return value[0] if len(value) == 1 else tuple(value)


def field_arrays(data, skip=("TimeConversion", "InsideTestReason")):
    """All field arrays as {name: value}, minus the per-run conversion time and the
    voxelizer-only InsideTestReason (a .hdt file records the test, not why)."""
    fd = data.GetFieldData()
    names = [fd.GetAbstractArray(i).GetName() for i in range(fd.GetNumberOfArrays())]
    return {n: field_value(data, n) for n in names if n not in skip}


def voxel_counts(htg):
    """Voxels covered by the unmasked leaf cells of each VoxelState, and the
    leaf cells themselves: {state: (voxels, leaves, leaves of one voxel)}.

    Leaves are turned into hexahedra by VTK's own filter, so this does not
    depend on how the plugin laid the trees out; a leaf's edge in voxels is its
    x extent over the voxel size."""
    voxel_size = field_value(htg, "VoxelSize")
    f = vtkHyperTreeGridToUnstructuredGrid()
    f.SetInputData(htg)
    f.Update()
    ug = f.GetOutput()
    if ug.GetNumberOfCells() == 0:
        return {}
    points = vtk_to_numpy(ug.GetPoints().GetData())
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray()).reshape(-1, 8)
    x = points[conn, 0]
    edge = np.rint((x.max(axis=1) - x.min(axis=1)) / voxel_size).astype(np.int64)
    voxels = edge ** 3
    state = vtk_to_numpy(ug.GetCellData().GetArray("VoxelState"))
    return {
        int(s): (int(voxels[state == s].sum()), int((state == s).sum()),
                 int(((state == s) & (edge == 1)).sum()))
        for s in np.unique(state)
    }


def _bits(bit_array):
    from vtkmodules.vtkCommonCore import vtkUnsignedCharArray

    a = vtkUnsignedCharArray()
    a.DeepCopy(bit_array)  # one byte a bit, for numpy
    return vtk_to_numpy(a).tobytes()


def htg_summary(htg):
    """What two hyper tree grids must share to be the same grid."""
    cd = htg.GetCellData()
    states = cd.GetArray("VoxelState")
    mask = htg.GetMask()
    coords = [htg.GetXCoordinates(), htg.GetYCoordinates(), htg.GetZCoordinates()]
    return {
        "class": htg.GetClassName(),
        "dimensions": tuple(htg.GetDimensions()),
        "branch_factor": htg.GetBranchFactor(),
        "cells": htg.GetNumberOfCells(),
        "leaves": htg.GetNumberOfLeaves(),
        "levels": htg.GetNumberOfLevels(),
        "trees": htg.GetNumberOfNonEmptyTrees(),
        "cell_arrays": sorted(cd.GetArrayName(i) for i in range(cd.GetNumberOfArrays())),
        "coordinates": [tuple(vtk_to_numpy(c)) if c else None for c in coords],
        "states": vtk_to_numpy(states).tobytes() if states else None,
        "mask": _bits(mask) if mask else None,
    }


def leaf_geometry(htg):
    """The unmasked leaves as VTK itself lays them out in space (corner points
    in cell order) with their states: equal for two grids only when their trees
    have the same shapes, cells, states and mask."""
    f = vtkHyperTreeGridToUnstructuredGrid()
    f.SetInputData(htg)
    f.Update()
    ug = f.GetOutput()
    if ug.GetNumberOfCells() == 0:
        return b"", b""
    points = vtk_to_numpy(ug.GetPoints().GetData())
    conn = vtk_to_numpy(ug.GetCells().GetConnectivityArray())
    states = vtk_to_numpy(ug.GetCellData().GetArray("VoxelState"))
    return points[conn].tobytes(), states.tobytes()


def run_cli(cli, args):
    """hdt-voxelize ARGS --json: its statistics as a dict."""
    result = subprocess.run([cli] + args + ["--json", "--quiet"], capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError("%s failed (%d): %s" % (cli, result.returncode, result.stderr))
    return json.loads(result.stdout)
