"""The HDT Voxelizer, Writer and Reader across MPI ranks (mpi_test.sh runs it).

Run by `pvbatch --symmetric` on every rank (or alone, for the serial
reference): each rank voxelizes the cases below from its own piece of the
input and writes a JSON digest of what it holds: per tree its VoxelState
values (breadth-first), the statistics, its voxel-surface quads, and the
digests of the HDT Reader's share of the serial .hdt. Rank 0 then checks the
union of the ranks' digests against the serial run's (`--reference`).

Cases:
  sphere     a closed mesh that ParaView's Sphere source splits over the ranks
             (Backend Auto: per rank the GPU or, without one, the CPU)
  open       an open cap under the default inside test (Auto): the winding
             number, serially and across ranks (there rank 0 classifies the
             joined surface and hands each rank its trees back)
  parity     the same cap under Parity (3-axis classification, cross-rank
             parities)
  blocks     a multiblock whose blocks lie on different ranks (rank i holds
             block i only; ranks past the block count hold nothing)
  onecolumn  RootGridSize 1: one row of root cells, so K > 1 ranks have more
             ranks than rows (all but one rank build nothing)
"""
import argparse
import hashlib
import json
import os
import sys

import numpy as np
from paraview import simple
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkParallelCore import vtkMultiProcessController

import hdt_testing as t

STATS = ("TreeElements", "LeafGrids", "LeafVoxels", "ActiveVoxels", "InsideVoxels",
         "PaperBitsPerActiveVoxel", "TopologyBytes", "LeafBytes", "Triangles",
         "DegenerateTriangles", "Resolution", "Height", "RootGridSize", "LeafGridSize",
         "SurfaceOnly", "ClosedMesh", "VoxelSize", "Origin", "Backend", "DisplayDepth", "FullDepth")

BLOCKS_SCRIPT = """
from vtkmodules.vtkParallelCore import vtkMultiProcessController
from vtkmodules.vtkFiltersSources import vtkSphereSource
from vtkmodules.vtkCommonDataModel import vtkMultiBlockDataSet, vtkPolyData
c = vtkMultiProcessController.GetGlobalController()
rank = c.GetLocalProcessId() if c else 0
ranks = c.GetNumberOfProcesses() if c else 1
out = self.GetOutput()
out.SetNumberOfBlocks(3)
for b, (x, r) in enumerate([(-1.0, 0.6), (0.2, 0.5), (1.2, 0.4)]):
    if b % ranks != rank:
        out.SetBlock(b, vtkPolyData())
        continue
    s = vtkSphereSource()
    s.SetCenter(x, 0.1 * b, 0.0)
    s.SetRadius(r)
    s.SetThetaResolution(24)
    s.SetPhiResolution(16)
    s.Update()
    out.SetBlock(b, s.GetOutput())
"""


def make_input(case):
    if case == "sphere" or case == "onecolumn":
        return simple.Sphere(ThetaResolution=48, PhiResolution=32)
    if case in ("open", "parity"):
        return simple.Sphere(ThetaResolution=48, PhiResolution=32, EndPhi=120.0)
    src = simple.ProgrammableSource()
    src.OutputDataSetType = "vtkMultiblockDataSet"
    src.Script = BLOCKS_SCRIPT
    return src


# Run by a Programmable Filter on every rank: the rank's digest of its piece
# as JSON (PATH names the file; %d is the rank).
DIGEST_SCRIPT = """
import hashlib, json
import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkParallelCore import vtkMultiProcessController
c = vtkMultiProcessController.GetGlobalController()
rank = c.GetLocalProcessId() if c else 0
data = self.GetInputDataObject(0, 0)
out = {}
if data.IsA("vtkHyperTreeGrid"):
    trees = {}
    states = data.GetCellData().GetArray("VoxelState")
    states = vtk_to_numpy(states) if states is not None else np.zeros(0, np.uint8)
    for index in range(data.GetMaxNumberOfTrees()):
        tree = data.GetTree(index)
        if tree is None:
            continue
        n = tree.GetNumberOfVertices()
        start = tree.GetGlobalIndexFromLocal(0)
        trees[str(index)] = [int(n), hashlib.sha1(states[start:start + n].tobytes()).hexdigest()]
    out["trees"] = trees
    out["split"] = data.GetFieldData().GetArray("RankRootRanges") is not None
    devices = data.GetFieldData().GetArray("RankDevices")
    out["devices"] = [int(devices.GetTuple1(i)) for i in range(devices.GetNumberOfTuples())] if devices else None
else:
    quads = []
    if data.GetNumberOfCells():
        pts = vtk_to_numpy(data.GetPoints().GetData()).reshape(-1, 4, 3)
        st = vtk_to_numpy(data.GetCellData().GetArray("VoxelState"))
        quads = ["%s|%d" % (np.round(np.sort(q, axis=0), 5).tolist(), s) for q, s in zip(pts, st)]
    out["quads"] = quads
stats = {}
fd = data.GetFieldData()
for name in STATS:
    a = fd.GetAbstractArray(name)
    if a is None:
        stats[name] = None
    elif a.IsA("vtkStringArray"):
        stats[name] = a.GetValue(0)
    else:
        stats[name] = list(a.GetTuple(0))
out["stats"] = stats
out["inside"] = [fd.GetAbstractArray(n).GetValue(0) if fd.GetAbstractArray(n) is not None else None
                 for n in ("InsideTest", "InsideTestReason")]
json.dump(out, open(PATH % rank, "w"))
if c:
    c.Barrier()
"""


def digest(proxy, port, path, ranks):
    """Each rank's digest of `proxy`'s output `port`, as a list by rank."""
    f = simple.ProgrammableFilter(Input=simple.OutputPort(proxy, port))
    f.OutputDataSetType = "vtkPolyData"
    f.Script = "STATS = %r\nPATH = %r\n" % (STATS, path) + DIGEST_SCRIPT
    f.UpdatePipeline()
    simple.Delete(f)
    return [json.load(open(path % r)) for r in range(ranks)]


def hdt_sections(path):
    """The .hdt's sections but the statistics (which hold times), as hashes."""
    data = open(path, "rb").read()
    at, out = 12, {}
    while at < len(data):
        sid = int.from_bytes(data[at:at + 4], "little")
        stored = int.from_bytes(data[at + 8:at + 16], "little")
        if sid != 2:
            out[str(sid)] = hashlib.sha1(data[at:at + 28 + stored]).hexdigest()
        at += 28 + stored
    return out


def merged(pieces, case, ranks):
    """The union of the ranks' digests of one case; checks that statistics agree."""
    trees, quads = {}, []
    for r, p in enumerate(pieces["htg"]):
        for tid, d in p["trees"].items():
            t.check(tid not in trees, "%s: tree %s is on one rank only" % (case, tid))
            trees[tid] = d
        t.check_equal(p["split"], ranks > 1, "%s: rank %d's grid says how it is split" % (case, r))
        # Backend CPU, or Auto on a machine without a usable GPU (the serial
        # reference's Backend statistic says which): every rank ran the CPU
        # driver, and RankDevices says so (-1).
        if p["stats"]["Backend"] == "cpu":
            t.check_equal(p["devices"], [-1] * ranks if ranks > 1 else None,
                          "%s: rank %d's grid says every rank ran on the CPU" % (case, r))
    for p in pieces["surface"]:
        quads += p["quads"]
    return {"trees": trees, "quads": sorted(quads), "stats": [p["stats"] for p in pieces["htg"]],
            "inside": [p.get("inside") for p in pieces["htg"]],
            "surface_stats": [p["stats"] for p in pieces["surface"]]}


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plugin", required=True)
    parser.add_argument("--tmp", required=True)
    parser.add_argument("--reference", required=True)
    parser.add_argument("--write-reference", action="store_true")
    args = parser.parse_args()
    ranks = simple.servermanager.ActiveConnection.GetNumberOfDataPartitions()
    tmp = os.path.join(args.tmp, "n%d" % ranks)
    os.makedirs(tmp, exist_ok=True)
    t.load_plugin(args.plugin, globals())
    print("ranks: %d" % ranks)

    result = {}
    for case in ("sphere", "open", "parity", "blocks", "onecolumn"):
        src = make_input(case)
        # The sphere with Backend Auto: each rank picks its own driver (with no
        # GPU: the CPU on every rank, as the serial run does).
        vox = HDTVoxelizer(Input=src, Resolution=64, RootGridSize=1 if case == "onecolumn" else 4,
                           LeafGridSize=8, Backend="Auto" if case == "sphere" else "CPU", MaxDepth=-1)
        if case == "parity":
            vox.InsideTest = "Parity"
        pieces = {"htg": digest(vox, 0, os.path.join(tmp, case + "-htg-%d.json"), ranks),
                  "surface": digest(vox, 1, os.path.join(tmp, case + "-surface-%d.json"), ranks)}
        entry = merged(pieces, case, ranks)
        # The writer gathers the ranks' trees; rank 0 writes one file.
        path = os.path.join(tmp, case + ".hdt")
        simple.SaveData(path, proxy=vox)
        entry["file"] = hdt_sections(path)
        # The reader hands each rank a share of the serial file's trees.
        serial_file = os.path.join(args.tmp, "n1", case + ".hdt")
        reader = simple.OpenDataFile(serial_file)
        read = merged({"htg": digest(reader, 0, os.path.join(tmp, case + "-read-%d.json"), ranks),
                       "surface": digest(reader, 1, os.path.join(tmp, case + "-reads-%d.json"), ranks)},
                      case + " (reader)", ranks)
        entry["read_trees"], entry["read_quads"] = read["trees"], read["quads"]
        for proxy in (reader, vox, src):
            simple.Delete(proxy)
        result[case] = entry

    if args.write_reference:
        json.dump(result, open(args.reference, "w"))
        print("wrote the serial reference")
        return
    ref = json.load(open(args.reference))
    for case, got in result.items():
        want = ref[case]
        t.check_equal(len(got["trees"]), len(want["trees"]), "%s: trees over %d ranks" % (case, ranks))
        t.check(got["trees"] == want["trees"], "%s: every tree's VoxelState equals the serial run's" % case)
        for r, stats in enumerate(got["stats"] + got["surface_stats"]):
            t.check_equal(stats, want["stats"][0], "%s: statistics on rank %d" % (case, r % ranks))
        t.check(got["quads"] == want["quads"],
                "%s: the ranks' voxel surfaces together are the serial one (%d quads)" % (case, len(got["quads"])))
        t.check_equal(got["file"], want["file"], "%s: the .hdt (every section but the statistics)" % case)
        t.check(got["read_trees"] == want["trees"], "%s: the reader's shares are the serial trees" % case)
        t.check(got["read_quads"] == want["quads"], "%s: the reader's surfaces are the serial surface" % case)
        if case == "open":
            for r, (test, reason) in enumerate(got["inside"]):
                t.check_equal(test, "winding", "open: rank %d ran the winding number under Auto" % r)
                t.check_equal(reason, "Auto: the mesh is open, winding number", "open: rank %d says why" % r)
    if t._failures:
        t.finish()  # prints them and exits non-zero
    # On success the script returns: pvbatch then finalizes MPI (sys.exit
    # would skip that, and mpiexec reports an abnormal termination).
    print("all checks passed")


if __name__ == "__main__":
    main()
