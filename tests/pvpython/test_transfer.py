"""Arrays To Transfer in pvpython: the HDT Voxelizer's point and cell array
selections carry input arrays onto the surface voxels of both outputs.

A Sphere source with Elevation (point data, a linear ramp along z) and the
cell ids (cell data) is voxelized at N = 64 with full depth. Checks:
  * nothing is transferred by default;
  * with Elevation selected, the hyper tree grid and the voxel surface have a
    float32 cell array Elevation; on the grid, the voxels (cells of the
    deepest level) that are surface voxels have values of the ramp at points
    within a voxel of the surface, the inside and outside voxels NaN;
  * the ramp's value at a surface voxel matches the elevation of its centre
    within the voxel's reach (the exact value is the core tests' business);
  * a cell array (CellIds) comes out as integers of the input's cell range.
"""
import math

from paraview.simple import *  # noqa: F401,F403 (pvpython idiom)
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonDataModel import vtkHyperTreeGridNonOrientedGeometryCursor

import numpy as np

import hdt_testing as t

args = t.parse_args()
t.load_plugin(args.plugin, globals())

N, R, L = 64, 4, 16
sphere = Sphere(ThetaResolution=32, PhiResolution=32, Radius=0.5)
generated = GenerateIds(Input=sphere)  # CellIds (5.11 drops other arrays: it comes first)
ids = Elevation(Input=generated, LowPoint=[0, 0, -0.5], HighPoint=[0, 0, 0.5])
ids.UpdatePipeline()
ids_name = "CellIds"

vox = HDTVoxelizer(Input=ids, Resolution=N, RootGridSize=R, LeafGridSize=L, Backend="CPU", MaxDepth=-1)
htg = t.fetch(vox)
t.check(htg.GetCellData().GetArray("Elevation") is None, "nothing transferred by default")

vox.PointArraysToTransfer = ["Elevation"]
vox.CellArraysToTransfer = [ids_name]
htg = t.fetch(vox)
arr = htg.GetCellData().GetArray("Elevation")
t.check(arr is not None, "HTG cell array Elevation exists")
if arr is not None:
    t.check_equal(arr.GetDataTypeAsString(), "float", "Elevation is float32")
    names = htg.GetFieldData().GetAbstractArray("TransferredArrays")
    t.check(names is not None and names.GetNumberOfValues() == 2, "field data TransferredArrays names both")

    # Walk every tree to its voxels: value vs the elevation of the voxel centre.
    state = htg.GetCellData().GetArray("VoxelState")
    cell_ids = htg.GetCellData().GetArray(ids_name)
    voxel = 1.0 / (N - 2)  # voxel size of a unit-extent mesh
    counts = {"surface": 0, "nan_inside_outside": 0, "bad": 0, "ids_bad": 0}
    cursor = vtkHyperTreeGridNonOrientedGeometryCursor()

    def visit(cursor):
        if not cursor.IsLeaf():
            for c in range(8):
                cursor.ToChild(c)
                visit(cursor)
                cursor.ToParent()
            return
        i = cursor.GetGlobalNodeIndex()
        value = arr.GetValue(i)
        if state.GetValue(i) == 2:
            b = [0.0] * 6
            cursor.GetBounds(b)
            z = 0.5 * (b[4] + b[5])
            counts["surface"] += 1
            # The closest surface point is within sqrt(3)/2 voxel of the centre.
            if not (abs(value - (z + 0.5)) <= 0.87 * voxel + 1e-6):
                counts["bad"] += 1
            cid = cell_ids.GetValue(i)
            if not (cid == int(cid) and 0 <= cid < ids.GetDataInformation().GetNumberOfCells()):
                counts["ids_bad"] += 1
        elif math.isnan(value):
            counts["nan_inside_outside"] += 1
        else:
            counts["bad"] += 1

    for tree in range(R ** 3):
        if htg.GetTree(tree) is None:
            continue
        htg.InitializeNonOrientedGeometryCursor(cursor, tree)
        visit(cursor)
    active = int(htg.GetFieldData().GetArray("ActiveVoxels").GetValue(0))
    t.check_equal(counts["surface"], active, "surface voxel cells")
    t.check_equal(counts["bad"], 0, "cells whose Elevation is off the ramp (or not NaN off the surface)")
    t.check_equal(counts["ids_bad"], 0, "surface cells whose Ids is not an input cell id")
    t.check(counts["nan_inside_outside"] > 0, "inside and outside voxels are NaN")

vox.UpdatePipeline()
surf = servermanager.Fetch(OutputPort(vox, 1))
sa = surf.GetCellData().GetArray("Elevation")
t.check(sa is not None and sa.GetNumberOfTuples() == surf.GetNumberOfCells(), "voxel surface has Elevation per quad")
if sa is not None:
    # Quads in front of surface voxels have a value of the ramp; others NaN.
    values = vtk_to_numpy(sa)
    on_surface = vtk_to_numpy(surf.GetCellData().GetArray("VoxelState")) == 2
    v = values[on_surface]
    t.check(v.size > 0 and np.all(np.isfinite(v)) and v.min() >= -0.05 and v.max() <= 1.05,
            "voxel surface Elevation of surface-voxel quads within the ramp")
    t.check(np.all(np.isnan(values[~on_surface])), "other quads NaN")

t.finish()
