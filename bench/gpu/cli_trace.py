# Where a hdt-voxelize process's time goes (issue 18; end-to-end.md, 2026-11-24 15:10-15:30 UTC).
# A binary built with bench/gpu/cli_trace.patch applied (HDT_TRACE=1: stamps of prepareCuda's and
# releaseCuda's steps on stderr; HDT_NO_PIN, HDT_NO_POOL, HDT_NO_WARMBUILD, HDT_NO_RELEASE,
# HDT_QUICK_EXIT switch steps off), beside this script as hdt-voxelize-trace, meshes in meshes/,
# libcudart in lib/; the HDT_PIN_MODE variants were a throw-away change of host_copy.cpp's ring
# (r: what it does now). Runs the variants alternating, one process a run; OUT, ROUNDS, MESHES,
# VARIANTS, PROBES (hdt_copy_bench --probe, from base/), E2E_ROUNDS (hdt_e2e_bench beside it).
import json, os, subprocess, sys, time
here = os.path.dirname(os.path.abspath(__file__)); root = os.path.abspath(os.path.join(here, '..', '..'))
out = os.environ.get('OUT', '/tmp/s9-18-out'); os.makedirs(out, exist_ok=True)
env0 = dict(os.environ)
env0['LD_LIBRARY_PATH'] = ':'.join([here + '/lib', root + '/.devdeps/lib/x86_64-linux-gnu', '/usr/local/cuda/lib64', env0.get('LD_LIBRARY_PATH', '')])
meshes = here + '/meshes/'
rounds = int(os.environ.get('ROUNDS', '3'))
jl = open(out + '/s9-18-probe.jsonl', 'a')
def run(cmd, env):
    s = time.time(); p = subprocess.run(cmd, env=env, capture_output=True, text=True); e = time.time()
    return s * 1000, e * 1000, p
def probe(how):
    s, e, p = run([here + '/base/hdt_copy_bench', '--probe', how], env0)
    r = {'kind': 'probe', 'how': how, 'process_wall_ms': round(e - s, 1), 'line': p.stdout.strip()}
    print(json.dumps(r)); jl.write(json.dumps(r) + '\n'); jl.flush()
VARS = {
 'base': ('hdt-voxelize-trace', {'HDT_TRACE': '1'}),
 'reg_huge': ('hdt-voxelize-trace', {'HDT_TRACE': '1', 'HDT_PIN_MODE': 'r'}),
 'reg_plain': ('hdt-voxelize-trace', {'HDT_TRACE': '1', 'HDT_PIN_MODE': 'u'}),
 'one_alloc': ('hdt-voxelize-trace', {'HDT_TRACE': '1', 'HDT_PIN_MODE': 'o'}),
 'nowarmbuild': ('hdt-voxelize-trace', {'HDT_TRACE': '1', 'HDT_NO_WARMBUILD': '1'}),
}
names = os.environ.get('VARIANTS', ' '.join(VARS)).split()
def cli(var, mesh, n):
    binp, extra = VARS[var]; env = dict(env0); env.update(extra)
    s, e, p = run([here + '/' + binp, meshes + mesh, '--resolution', str(n), '--backend', 'cuda', '-o', '/tmp/s9-18.hdt', '--json', '--quiet'], env)
    try: d = json.loads(p.stdout)
    except Exception: d = {'error': p.stdout[-300:] + p.stderr[-300:]}
    io = d.get('io_ms', {})
    tr = {}
    for l in p.stderr.splitlines():
        if l.startswith('trace '):
            _, k, v = l.split(); tr[k] = round(float(v) - io.get('unix_at_main', s), 1)
    r = {'kind': 'cli', 'variant': var, 'mesh': mesh, 'n': n, 'rc': p.returncode, 'process_wall_ms': round(e - s, 1),
         'before_main_ms': round(io.get('unix_at_main', s) - s, 1), 'after_report_ms': round(e - io.get('unix_at_report', e), 1),
         'report_at_ms': round(io.get('unix_at_report', 0) - io.get('unix_at_main', 0), 1),
         'io_ms': io, 'trace_ms_after_main': tr}
    print(f"{var:12} {mesh[:10]:10} wall {r['process_wall_ms']:6.1f} before {r['before_main_ms']:5.1f} report@ {r['report_at_ms']:6.1f} after {r['after_report_ms']:5.1f} | read {io.get('read',-1):5.1f} prep {io.get('prepare',-1):5.1f} dev {io.get('device_wait',-1):6.1f} build {io.get('build',-1):5.1f} write {io.get('write',-1):5.1f} rel {io.get('release_wait',-1):5.1f} | " + ' '.join(f'{k}={v}' for k, v in tr.items()), flush=True)
    jl.write(json.dumps(r) + '\n'); jl.flush()
if os.environ.get('PROBES', '1') == '1':
    for i in range(rounds):
        for how in ['none', 'ctx', 'reset', 'all']: probe(how)
for i in range(rounds):
    for mesh in os.environ.get('MESHES', 'stanford-dragon-100k.ply nefertiti.ply').split():
        for v in names: cli(v, mesh, int(os.environ.get('RES', '8192')))

def e2e(var, mesh):
    binp, extra = VARS[var]; env = dict(env0); env.update(extra)
    p = subprocess.run([here + '/hdt_e2e_bench', meshes + mesh, '--res', '8192', '--mode', 'solid', '--backend', 'cuda', '--hdt', '/tmp/s9-18-e2e.hdt', '--out', out + '/s9-18-e2e.jsonl'], env=env, capture_output=True, text=True)
    r = json.loads(open(out + '/s9-18-e2e.jsonl').read().splitlines()[-1]); r['variant'] = var
    print(f"e2e {var:12} {mesh[:10]} wait {r.get('warm_up_wait_ms',-1):6.1f} build {r.get('build_wall_ms',-1):6.1f} copy {r.get('copy_back_ms',-1):6.1f} ({r.get('copy_back_gb_per_s',-1):5.1f} GB/s) write {r.get('write_ms',-1):6.1f} wall {r.get('wall_ms',-1):6.1f} rc {p.returncode}", flush=True)
for i in range(int(os.environ.get('E2E_ROUNDS', '0'))):
    for mesh in os.environ.get('MESHES', 'stanford-dragon-100k.ply nefertiti.ply').split():
        for v in os.environ.get('E2E_VARIANTS', 'base reg_huge one_alloc').split(): e2e(v, mesh)
