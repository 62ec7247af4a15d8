#!/usr/bin/env python3
"""CPU benchmark: hdt-voxelize (CPU driver) against OpenVDB meshToVolume.

Builds build-bench (Release, -DHDT_BUILD_BENCH=ON), then for every mesh in
../shared/meshes and every resolution runs, each measurement in its own
process under /usr/bin/time:

  hdt-voxelize MESH --resolution N --backend cpu --json        (solid)
  hdt-voxelize MESH --resolution N --backend cpu --json --surface-only  (4096 only)
  openvdb_mesh_to_volume MESH --resolution N   (same voxel size and placement)

Appends one JSON line per run to bench/results/cpu-runs.jsonl (the tool's own
keys + tool, mode, rep, session, machine, date, wall_s, rss_max_bytes,
loadavg_1m) and one line per skipped measurement (with "skipped": reason),
then writes bench/results/cpu-table1.md from the lines of this session.

Run lengths are chosen so the whole run stays within --budget-min minutes:
  * 1024, 2048: median of 3 runs for both tools;
  * 4096: HDT 3 runs; OpenVDB 3 runs on the target meshes, 1 on the others;
  * 8192: HDT 3 runs (1 when one run is estimated above 30 s); OpenVDB 1 run,
    first on the target meshes, then on the others while the budget lasts.
Before each measurement its peak memory and time are estimated from the same
tool on the same mesh one resolution lower (x5 memory, x4.5 time: surface
voxels grow 4x per doubling); it is skipped, with the reason recorded, when the
estimate exceeds the memory limit (min(--mem-limit-gib, 80% of MemAvailable))
or the time left in the budget.

  bench/run_cpu_bench.py                 # build, run, write the table
  bench/run_cpu_bench.py --table-only    # rewrite the table from the JSON lines
"""
import argparse
import datetime
import json
import os
import platform
import shlex
import statistics
import subprocess
import sys
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TARGET_MESHES = ["stanford-dragon-100k.ply", "nefertiti.obj"]
MESH_EXTS = (".ply", ".obj", ".stl")
MEM_GROWTH = 5.0   # peak memory, per resolution doubling (estimates only; up to 5.5x seen on thin plates)
TIME_GROWTH = 4.5  # run time, per resolution doubling (estimates only)
GIB = 1 << 30
NICE = 0  # set from --nice


def log(msg):
    print(time.strftime("%H:%M:%S"), msg, flush=True)


# ---- machine -------------------------------------------------------------------

def machine_info():
    model = "unknown CPU"
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    model = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    mem_kb = 0
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemTotal:"):
                    mem_kb = int(line.split()[1])
    except OSError:
        pass
    cores = os.cpu_count() or 1
    return "%s, %d cores, %.1f GiB, %s" % (model, cores, mem_kb / (1 << 20), platform.platform())


def mem_available():
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    return 0


def cpu_idle(seconds=0.5):
    """Fraction of all CPUs idle over a short sample (instantaneous, unlike loadavg)."""
    def snap():
        with open("/proc/stat") as f:
            v = [int(x) for x in f.readline().split()[1:]]
        return v[3] + v[4], sum(v)  # idle + iowait, total
    i0, t0 = snap()
    time.sleep(seconds)
    i1, t1 = snap()
    return (i1 - i0) / max(1, t1 - t0)


def wait_quiet(threshold, max_wait):
    """Waits (up to max_wait s) until the CPUs are at least `threshold` idle; returns the last idle fraction."""
    deadline = time.time() + max_wait
    idle = cpu_idle()
    while idle < threshold and time.time() < deadline:
        time.sleep(2)
        idle = cpu_idle()
    return idle


def loadavg():
    try:
        with open("/proc/loadavg") as f:
            return float(f.read().split()[0])
    except OSError:
        return None


# ---- build ---------------------------------------------------------------------

def build(build_dir):
    cfg = ["cmake", "-S", REPO, "-B", build_dir, "-G", "Ninja", "-DCMAKE_BUILD_TYPE=Release",
           "-DHDT_BUILD_PARAVIEW=OFF", "-DHDT_ENABLE_CUDA=OFF", "-DHDT_BUILD_BENCH=ON"]
    log("configure: " + " ".join(cfg))
    subprocess.run(cfg, check=True, stdout=subprocess.DEVNULL)
    cmd = ["ninja", "-C", build_dir, "hdt-voxelize", "openvdb_mesh_to_volume"]
    log("build: " + " ".join(cmd))
    subprocess.run(cmd, check=True)


def find_exe(build_dir, name):
    for sub in ("apps", "bench", ""):
        p = os.path.join(build_dir, sub, name)
        if os.path.isfile(p) and os.access(p, os.X_OK):
            return p
    for root, _, files in os.walk(build_dir):
        if name in files and os.access(os.path.join(root, name), os.X_OK):
            return os.path.join(root, name)
    return None


# ---- one measurement -----------------------------------------------------------

def run_once(cmd, timeout):
    """Runs cmd under /usr/bin/time; returns (json dict, wall_s, max_rss_bytes, cpu_s) or raises."""
    tfile = "/tmp/hdt-bench-time.%d" % os.getpid()
    full = ["/usr/bin/time", "-f", "%e %M %U %S", "-o", tfile] + cmd
    if NICE:
        full = ["nice", "-n", str(NICE)] + full
    t0 = time.time()
    p = subprocess.run(full, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout)
    wall = time.time() - t0
    if p.returncode != 0:
        raise RuntimeError("exit %d: %s" % (p.returncode, (p.stderr or "").strip()[-400:]))
    line = [l for l in p.stdout.splitlines() if l.strip().startswith("{")]
    if not line:
        raise RuntimeError("no JSON line in output: %r" % p.stdout[-400:])
    data = json.loads(line[-1])
    rss = cpu = None
    try:
        with open(tfile) as f:
            parts = f.read().split()
            wall, rss, cpu = float(parts[-4]), int(parts[-3]) * 1024, float(parts[-2]) + float(parts[-1])
        os.unlink(tfile)
    except (OSError, ValueError, IndexError):
        pass
    return data, wall, rss, cpu


class Bench:
    def __init__(self, args):
        self.args = args
        self.session = datetime.datetime.now(datetime.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
        self.machine = machine_info()
        self.deadline = time.time() + 60 * args.budget_min
        self.out = open(args.jsonl, "a")
        # (tool, mesh, mode, N) -> (median time s incl. process, max peak bytes), for estimates
        self.measured = {}
        self.patience = args.quiet_wait  # shrinks to 5 s after a wait that timed out (a busy machine)

    def record(self, obj):
        obj.setdefault("session", self.session)
        obj.setdefault("machine", self.machine)
        obj.setdefault("date", datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"))
        self.out.write(json.dumps(obj) + "\n")
        self.out.flush()

    def estimate(self, tool, mesh, mode, n):
        prev = self.measured.get((tool, mesh, mode, n // 2))
        if prev is None:
            return None
        return prev[0] * TIME_GROWTH, prev[1] * MEM_GROWTH

    def skip(self, tool, mesh, mode, n, reason):
        log("SKIP %s %s %s %d: %s" % (tool, mesh, mode, n, reason))
        self.record({"tool": tool, "mesh": mesh, "mode": mode, "resolution": n, "skipped": reason})

    def measure(self, tool, mesh, mode, n, cmd, reps, first_size):
        est = self.estimate(tool, mesh, mode, n)
        if est is None and not first_size:
            return self.skip(tool, mesh, mode, n, "no measurement at %d to estimate from" % (n // 2))
        limit = min(self.args.mem_limit_gib * GIB, 0.8 * mem_available())
        left = self.deadline - time.time()
        if est is not None:
            t_est, m_est = est
            if m_est > limit:
                return self.skip(tool, mesh, mode, n, "memory: estimated peak %.1f GiB > limit %.1f GiB"
                                 % (m_est / GIB, limit / GIB))
            if t_est > left:
                return self.skip(tool, mesh, mode, n, "time budget: estimated %.0f s > %.0f s left"
                                 % (t_est, max(left, 0)))
            if reps > 1 and t_est * reps > left:
                reps = 1
        times, peaks = [], []
        for rep in range(reps):
            idle = None
            if self.args.quiet_idle > 0:
                idle = wait_quiet(self.args.quiet_idle, self.patience)
                self.patience = self.args.quiet_wait if idle >= self.args.quiet_idle else 5
            load = loadavg()
            try:
                data, wall, rss, cpu = run_once(cmd, self.args.run_timeout)
            except subprocess.TimeoutExpired:
                return self.skip(tool, mesh, mode, n, "timed out after %d s" % self.args.run_timeout)
            except (RuntimeError, ValueError) as e:
                log("FAIL %s" % e)
                self.record({"tool": tool, "mesh": mesh, "mode": mode, "resolution": n,
                             "skipped": "failed: %s" % e, "command": " ".join(map(shlex.quote, cmd))})
                return
            data.update({"tool": tool, "mesh": mesh, "mesh_path": data.get("mesh"), "mode": mode, "rep": rep,
                         "reps": reps, "nice": NICE, "wall_s": wall, "cpu_s": cpu,
                         "cpu_util": (cpu / (wall * (data.get("threads") or 1))) if cpu and wall else None,
                         "idle_before": idle, "rss_max_bytes": rss, "loadavg_1m": load,
                         "command": " ".join(map(shlex.quote, cmd))})
            self.record(data)
            t_ms = data["time_ms"]["total"] if isinstance(data.get("time_ms"), dict) else data.get("time_ms")
            log("%-8s %-26s %-8s %5d rep %d: %8.1f ms build, %6.1f s wall, %7.0f MiB peak, load %.2f, "
                "idle before %.2f, util %.2f"
                % (tool, mesh, mode, n, rep, t_ms, wall, (rss or data.get("peak_host_bytes", 0)) / 2**20,
                   load or 0, idle if idle is not None else -1, data["cpu_util"] or -1))
            times.append(wall)
            peaks.append(rss or data.get("peak_host_bytes", 0))
        self.measured[(tool, mesh, mode, n)] = (statistics.median(times), max(peaks))


def run_all(args):
    bench = Bench(args)
    log("machine: " + bench.machine + "; session " + bench.session)
    meshes = sorted(f for f in os.listdir(args.meshes) if f.lower().endswith(MESH_EXTS))
    if args.only:
        meshes = [m for m in meshes if m in args.only]
    meshes.sort(key=lambda m: (m not in TARGET_MESHES, TARGET_MESHES.index(m) if m in TARGET_MESHES else 0, m))
    resolutions = [int(r) for r in args.resolutions.split(",")]
    hdt, vdb = args.hdt_exe, args.vdb_exe
    deferred = []
    for mesh in meshes:
        path = os.path.join(args.meshes, mesh)
        for i, n in enumerate(resolutions):
            first = i == 0
            est = bench.estimate("hdt-cpu", mesh, "solid", n)
            hdt_reps = 1 if (n >= 8192 and est and est[0] > 30) else 3
            bench.measure("hdt-cpu", mesh, "solid", n,
                          [hdt, path, "--resolution", str(n), "--backend", "cpu", "--json"], hdt_reps, first)
            if n == args.surface_resolution:
                bench.measure("hdt-cpu", mesh, "surface", n,
                              [hdt, path, "--resolution", str(n), "--backend", "cpu", "--json",
                               args.surface_flag], 3, True)
            vdb_cmd = [vdb, path, "--resolution", str(n)]
            if n >= 8192 and mesh not in TARGET_MESHES:
                deferred.append((mesh, n, vdb_cmd))
                continue
            vdb_reps = 3 if (n <= 2048 or (n == 4096 and mesh in TARGET_MESHES)) else 1
            bench.measure("openvdb", mesh, "udf", n, vdb_cmd, vdb_reps, first)
    # OpenVDB at 8192 on the other meshes, cheapest first, while the budget lasts.
    deferred.sort(key=lambda d: (bench.estimate("openvdb", d[0], "udf", d[1]) or (1e9, 0))[0])
    for mesh, n, cmd in deferred:
        bench.measure("openvdb", mesh, "udf", n, cmd, 1, False)
    bench.out.close()
    return bench.session


# ---- the table -----------------------------------------------------------------

def load_lines(path, session):
    """Lines of the chosen session(s): "latest", one id, or ids joined by commas;
    with several, a measurement (tool, mesh, mode, N) is taken from the last
    listed session that has it (e.g. a quieter re-run of a few rows)."""
    rows = []
    with open(path) as f:
        for line in f:
            line = line.strip()
            if line:
                rows.append(json.loads(line))
    sessions = sorted({r.get("session") for r in rows if r.get("tool") in ("hdt-cpu", "openvdb") and r.get("session")})
    if not sessions:
        return [], None
    wanted = [sessions[-1]] if session in (None, "latest") else session.split(",")
    key = lambda r: (r.get("tool"), r.get("mesh"), r.get("mode"), r.get("resolution"))
    owner = {}
    for sid in wanted:
        for r in rows:
            if r.get("session") == sid:
                owner[key(r)] = sid
    return [r for r in rows if r.get("session") in wanted and owner.get(key(r)) == r.get("session")], \
        ",".join(wanted)


def med(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None


def fmt_int(v):
    return "–" if v is None else "{:,}".format(int(round(v)))


def fmt_mib(v):
    return "–" if v is None else "{:,.0f}".format(v / 2**20)


def fmt_f(v, d=2):
    return "–" if v is None else ("{:,.%df}" % d).format(v)


def fmt_ms(v):
    if v is None:
        return "–"
    return "{:,.0f}".format(v) if v >= 100 else "{:,.1f}".format(v)


def paper_rows(csv_path):
    out = {}
    try:
        with open(csv_path) as f:
            header = None
            for line in f:
                if line.startswith("#") or not line.strip():
                    continue
                cells = line.strip().split(",")
                if header is None:
                    header = cells
                    continue
                row = dict(zip(header, cells))
                out[(row["model"], int(row["resolution"]))] = row
    except OSError:
        pass
    return out


PAPER_MATCH = {"stanford-dragon-100k.ply": "Dragon", "turbine-blade.stl": "Turbine"}


def write_table(args, session=None):
    rows, session = load_lines(args.jsonl, session)
    if not rows:
        log("no runs in %s" % args.jsonl)
        return
    groups, skips = {}, {}
    for r in rows:
        key = (r["tool"], r["mesh"], r.get("mode"), int(r["resolution"]))
        if "skipped" in r:
            skips[key] = r["skipped"]
        else:
            groups.setdefault(key, []).append(r)

    def total_ms(r):
        t = r.get("time_ms")
        return t.get("total") if isinstance(t, dict) else t

    def agg(key):
        g = groups.get(key)
        if not g:
            return None
        a = {"n": len(g), "first": g[0]}
        a["total"] = med([total_ms(r) for r in g])
        if isinstance(g[0].get("time_ms"), dict):
            for ph in ("mapping", "branching", "leaf", "classify"):
                a[ph] = med([r["time_ms"].get(ph) for r in g])
        a["peak"] = med([r.get("rss_max_bytes") or r.get("peak_host_bytes") for r in g])
        a["wall"] = med([r.get("wall_s") for r in g])
        a["load"] = max((r.get("loadavg_1m") or 0) for r in g)
        a["util"] = med([r.get("cpu_util") for r in g])
        a["best"] = min(t for t in (total_ms(r) for r in g) if t is not None)
        a["cpu"] = med([r.get("cpu_s") for r in g])
        return a

    machine = rows[0].get("machine", "?")
    dates = sorted(r.get("date", "") for r in rows)
    meshes = sorted({k[1] for k in list(groups) + list(skips)},
                    key=lambda m: (m not in TARGET_MESHES, TARGET_MESHES.index(m) if m in TARGET_MESHES else 0, m))
    resolutions = sorted({k[3] for k in list(groups) + list(skips)})
    paper = paper_rows(os.path.join(REPO, "..", "shared", "paper-table1.csv"))
    any_hdt = next((g[0] for k, g in groups.items() if k[0] == "hdt-cpu"), {})
    any_vdb = next((g[0] for k, g in groups.items() if k[0] == "openvdb"), {})

    L = []
    w = L.append
    w("# HDT CPU builder vs OpenVDB meshToVolume: Table 1 on this machine")
    w("")
    w("Generated by `bench/run_cpu_bench.py` from `bench/results/cpu-runs.jsonl` (session(s) `%s`). "
      "Do not edit by hand; rerun `bench/run_cpu_bench.py --table-only` to regenerate." % session)
    w("")
    w("- **Machine**: %s" % machine)
    w("- **Date**: %s to %s (UTC)" % (dates[0], dates[-1]))
    w("- **HDT**: `hdt-voxelize MESH --resolution N --backend cpu --json` (root grid %s, leaf %s, %s threads), "
      "solid mode unless marked surface-only." % (any_hdt.get("root_grid", "?"), any_hdt.get("leaf_size", "?"),
                                                  any_hdt.get("threads", "?")))
    w("- **OpenVDB** %s: `tools::meshToUnsignedDistanceField<FloatGrid>` (TBB, %s threads) at the HDT's voxel size "
      "and voxel centres, narrow band half-width sqrt(3)/2 voxel (every voxel whose cube meets the surface is "
      "active), `bench/openvdb_mesh_to_volume`." % (any_vdb.get("openvdb_version", ""), any_vdb.get("threads", "?")))
    w("- **Times** are build times: HDT `time_ms.total` (mapping + branching + leaf + classify; mesh reading and "
      "snapping excluded), OpenVDB the `meshToUnsignedDistanceField` call (mesh reading excluded). "
      "**Peak** is the process's maximum resident set size (`/usr/bin/time`, each measurement its own process; "
      "it includes the mesh as read). Medians of the runs counted in column *runs*.")
    w("- **Ratios**: speed-up = OpenVDB time / HDT time; memory fraction = HDT peak / OpenVDB peak.")
    w("- The machine is shared. Before each run the script waits (up to 90 s) for the CPUs to be 80 %% idle. "
      "*CPU use* = process CPU time / (wall time x threads), median: near 1 means the run had the cores to "
      "itself (minus its serial parts), well below 1 that it was starved. *load* is the highest 1-minute load "
      "average seen before a run (%d cores)." % (os.cpu_count() or 1))
    w("")

    # ---- targets
    w("## Targets")
    w("")
    w("| Target | Mesh | Measured | Met? |")
    w("|---|---|---:|:---:|")
    verdicts = []
    for mesh in TARGET_MESHES:
        h, v = agg(("hdt-cpu", mesh, "solid", 4096)), agg(("openvdb", mesh, "udf", 4096))
        if h and v:
            sp = v["total"] / h["total"]
            mf = h["peak"] / v["peak"]
            ok1, ok2 = sp >= 10, mf <= 0.25
            verdicts += [ok1, ok2]
            w("| CPU build >= 10x faster than OpenVDB at 4096^3 | %s | %.1fx (median %s ms vs %s ms; best runs "
              "%s vs %s ms: %.1fx) | %s |"
              % (mesh, sp, fmt_ms(h["total"]), fmt_ms(v["total"]), fmt_ms(h["best"]), fmt_ms(v["best"]),
                 v["best"] / h["best"], "yes" if ok1 else "**no**"))
            if h.get("cpu") and v.get("cpu"):
                w("| (same, in CPU time: whole process, user + sys, insensitive to other load) | %s | %.1fx "
                  "(%s s vs %s s) | |" % (mesh, v["cpu"] / h["cpu"], fmt_f(h["cpu"]), fmt_f(v["cpu"])))
            w("| CPU peak memory <= 1/4 of OpenVDB's at 4096^3 | %s | %.3f (%s MiB vs %s MiB) | %s |"
              % (mesh, mf, fmt_mib(h["peak"]), fmt_mib(v["peak"]), "yes" if ok2 else "**no**"))
        else:
            w("| speed / memory at 4096^3 | %s | not measured | – |" % mesh)
    for mesh in meshes:
        h = agg(("hdt-cpu", mesh, "solid", 4096))
        if h:
            b = h["first"].get("paper_bits_per_active_voxel")
            ok = b is not None and b <= 2.0
            if mesh in TARGET_MESHES:
                verdicts.append(ok)
            w("| paper topology <= 2 bits / active voxel at 4096^3 | %s | %s | %s |"
              % (mesh, fmt_f(b), "yes" if ok else "**no**"))
    w("")
    w("Targets on the two target meshes: **%s**." % ("all met" if verdicts and all(verdicts)
                                                     else "NOT all met" if verdicts else "not measured"))
    w("")

    # ---- per mesh
    for mesh in meshes:
        h0 = next((g[0] for k, g in groups.items() if k[0] == "hdt-cpu" and k[1] == mesh), None)
        w("## %s" % mesh)
        w("")
        if h0:
            w("%s triangles (%s degenerate dropped), closed mesh: %s." % (
                fmt_int(h0.get("triangles")), fmt_int(h0.get("degenerate_triangles")),
                "yes" if h0.get("closed_mesh") else "no (3-axis majority vote)"))
            w("")
        w("Structure (Table 1 columns; topology bytes = 4 bytes an element here, leaf bytes = 1 KiB a 16^3 leaf):")
        w("")
        w("| N | height | tree elements | leaf grids | leaf voxels | active voxels | inside voxels | "
          "paper bits/active voxel | topology bytes | leaf bytes |")
        w("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for n in resolutions:
            a = agg(("hdt-cpu", mesh, "solid", n))
            if a:
                f = a["first"]
                w("| %d | %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                    n, f.get("height"), fmt_int(f.get("tree_elements")), fmt_int(f.get("leaf_grids")),
                    fmt_int(f.get("leaf_voxels")), fmt_int(f.get("active_voxels")), fmt_int(f.get("inside_voxels")),
                    fmt_f(f.get("paper_bits_per_active_voxel")), fmt_int(f.get("topology_bytes")),
                    fmt_int(f.get("leaf_bytes"))))
            elif ("hdt-cpu", mesh, "solid", n) in skips:
                w("| %d | skipped: %s |||||||||" % (n, skips[("hdt-cpu", mesh, "solid", n)]))
        if mesh in PAPER_MATCH:
            model = PAPER_MATCH[mesh]
            prow = [(n, paper.get((model, n))) for n in (1024, 2048, 4096, 8192)]
            if any(p for _, p in prow):
                w("")
                w("The paper's %s (%s triangles; Table 1, GTX 780 Ti) beside ours (elements and leaf grids in "
                  "thousands, voxels in millions):" % (model, fmt_int(float(prow[0][1]["triangles"])) if prow[0][1] else "?"))
                w("")
                w("| N | height paper / ours | elements k paper / ours | leaf grids k paper / ours | "
                  "leaf voxels M paper / ours | active voxels M paper / ours | bits/active voxel paper / ours |")
                w("|---:|---:|---:|---:|---:|---:|---:|")
                for n, p in prow:
                    if not p:
                        continue
                    a = agg(("hdt-cpu", mesh, "solid", n))
                    f = a["first"] if a else {}
                    def ours(k, div):
                        return fmt_f(f[k] / div, 1 if div > 1 else 2) if f.get(k) is not None else "–"
                    w("| %d | %s / %s | %s / %s | %s / %s | %s / %s | %s / %s | %s / %s |" % (
                        n, p["height"], f.get("height", "–"), p["tree_elements_k"], ours("tree_elements", 1e3),
                        p["leaf_grids_k"], ours("leaf_grids", 1e3), p["leaf_voxels_m"], ours("leaf_voxels", 1e6),
                        p["active_voxels_m"], ours("active_voxels", 1e6), p["bits_per_active_voxel"],
                        ours("paper_bits_per_active_voxel", 1)))
        w("")
        w("Time (ms, median) and peak memory (MiB), HDT CPU beside OpenVDB:")
        w("")
        w("| N | mode | runs | mapping | branching | leaf | classify | **HDT total** | HDT peak | OpenVDB runs | "
          "**OpenVDB time** | OpenVDB peak | OpenVDB active voxels | **speed-up** | **memory fraction** | "
          "wall s HDT / OpenVDB | CPU use HDT / OpenVDB | load |")
        w("|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
        for n in resolutions:
            for mode in ("solid", "surface"):
                h = agg(("hdt-cpu", mesh, mode, n))
                v = agg(("openvdb", mesh, "udf", n))
                hs = skips.get(("hdt-cpu", mesh, mode, n))
                vs = skips.get(("openvdb", mesh, "udf", n))
                if not h and not hs and (mode == "surface" or not v):
                    continue
                cells = ["%d" % n, mode if mode == "solid" else "surface-only"]
                if h:
                    cells += [str(h["n"]), fmt_ms(h.get("mapping")), fmt_ms(h.get("branching")), fmt_ms(h.get("leaf")),
                              fmt_ms(h.get("classify")), "**%s**" % fmt_ms(h["total"]), fmt_mib(h["peak"])]
                else:
                    cells += ["–"] * 5 + ["skipped: %s" % hs if hs else "–", "–"]
                if v:
                    cells += [str(v["n"]), "**%s**" % fmt_ms(v["total"]), fmt_mib(v["peak"]),
                              fmt_int(v["first"].get("active_voxels"))]
                else:
                    cells += ["–", "skipped: %s" % vs if vs else "–", "–", "–"]
                if h and v:
                    cells += ["**%.1fx**" % (v["total"] / h["total"]), "**%.3f**" % (h["peak"] / v["peak"]),
                              "%s / %s" % (fmt_f(h["wall"], 1), fmt_f(v["wall"], 1))]
                else:
                    cells += ["–", "–", "–"]
                cells.append("%s / %s" % (fmt_f(h.get("util") if h else None), fmt_f(v.get("util") if v else None)))
                cells.append(fmt_f(max(h["load"] if h else 0, v["load"] if v else 0), 1))
                w("| " + " | ".join(cells) + " |")
        w("")

    # ---- paper figure 3
    w("## The paper's timings for reference")
    w("")
    w("Fig. 3 of the paper (GTX 780 Ti GPU, 8192^3): branching T2 = 1.93 s (Dragon), 2.17 s (Turbine), "
      "2.39 s (Candle Holder); leaf processing T3 = 1.23-1.29 s for all four models; mapping T1 about 2 %% of the "
      "total for Head and Dragon. Those are GPU times on larger meshes (Dragon 173K triangles); the rows above are "
      "a CPU build on %d cores and are not directly comparable." % (os.cpu_count() or 1))
    w("")
    if skips:
        w("## Skipped measurements")
        w("")
        for (tool, mesh, mode, n), why in sorted(skips.items(), key=lambda kv: (kv[0][1], kv[0][3], kv[0][0])):
            w("- %s %s %s at %d: %s" % (tool, mesh, mode, n, why))
        w("")
    with open(args.table, "w") as f:
        f.write("\n".join(L))
    log("wrote %s" % args.table)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--meshes", default=os.path.join(REPO, "..", "shared", "meshes"))
    ap.add_argument("--build-dir", default=os.path.join(REPO, "build-bench"))
    ap.add_argument("--results", default=os.path.join(REPO, "bench", "results"))
    ap.add_argument("--resolutions", default="1024,2048,4096,8192")
    ap.add_argument("--surface-resolution", type=int, default=4096)
    ap.add_argument("--surface-flag", default="--surface-only", help="the CLI's surface-only option")
    ap.add_argument("--budget-min", type=float, default=40)
    ap.add_argument("--mem-limit-gib", type=float, default=20)
    ap.add_argument("--run-timeout", type=int, default=900)
    ap.add_argument("--only", nargs="*", help="mesh file names to run (default: all)")
    ap.add_argument("--nice", type=int, default=-10 if os.geteuid() == 0 else 0,
                    help="niceness of the measured processes (default -10 as root: the machine is shared, "
                         "and a higher priority keeps other people's builds from skewing the timings)")
    ap.add_argument("--quiet-idle", type=float, default=0.8,
                    help="before each run wait until this fraction of the CPUs is idle (0: do not wait)")
    ap.add_argument("--quiet-wait", type=float, default=90, help="longest wait for --quiet-idle, seconds")
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--session", default="latest",
                    help="--table-only: session id, or ids joined by commas (later ones replace the rows they have)")
    ap.add_argument("--hdt-exe", help="default: BUILD/apps/hdt-voxelize")
    ap.add_argument("--vdb-exe", help="default: BUILD/bench/openvdb_mesh_to_volume")
    args = ap.parse_args()
    os.makedirs(args.results, exist_ok=True)
    args.jsonl = os.path.join(args.results, "cpu-runs.jsonl")
    args.table = os.path.join(args.results, "cpu-table1.md")
    if args.table_only:
        write_table(args, args.session)
        return 0
    global NICE
    NICE = args.nice
    if not args.no_build:
        build(args.build_dir)
    args.hdt_exe = args.hdt_exe or find_exe(args.build_dir, "hdt-voxelize")
    args.vdb_exe = args.vdb_exe or find_exe(args.build_dir, "openvdb_mesh_to_volume")
    if not args.hdt_exe or not args.vdb_exe:
        sys.exit("missing executables: hdt-voxelize=%s openvdb_mesh_to_volume=%s" % (args.hdt_exe, args.vdb_exe))
    session = run_all(args)
    write_table(args, session)
    return 0


if __name__ == "__main__":
    sys.exit(main())
