"""Time every stage of one CLI run in this (fresh) process: wall and CPU, JSON on the last stdout line.

usage: python stages.py IN OUT [CLI ARGS...]
"""
import json, os, sys, time
T0 = (time.perf_counter(), time.process_time())
import resource
acc = {}
stack = []

def timed(fn, label):
    def w(*a, **k):
        t = (time.perf_counter(), time.process_time())
        stack.append(label)
        try:
            return fn(*a, **k)
        finally:
            stack.pop()
            d = acc.setdefault(label, [0.0, 0.0, 0])
            d[0] += time.perf_counter() - t[0]; d[1] += time.process_time() - t[1]; d[2] += 1
    w.__wrapped__ = fn
    return w

import anglesmooth.cli.main as cm
import anglesmooth.cli.smooth as cs
T1 = (time.perf_counter(), time.process_time())
acc["import (anglesmooth, click, rich, numpy)"] = [T1[0]-T0[0], T1[1]-T0[1], 1]
from anglesmooth import io as mio, _paths, report
from anglesmooth._paths import staging
for name in ["read_mesh", "check_output", "build_topology", "fixed_mask", "summarize", "warn_invalid", "run_smooth",
             "evaluate", "write_mesh", "emit_json", "note_fast", "note_stale", "check_paths", "compile_estimate", "kernel_mode"]:
    setattr(cs, name, timed(getattr(cs, name), "cli." + name))
for name in ["_read_meshio", "_to_mesh2d", "_out_mesh", "_write_meshio"]:
    setattr(mio, name, timed(getattr(mio, name), "  io." + name))
staging._fsync = timed(staging._fsync, "  fsync")
staging._Staged.rename = timed(staging._Staged.rename, "commit.rename")
report.smooth_table = timed(report.smooth_table, "report.smooth_table")
report.smooth_json = timed(report.smooth_json, "report.smooth_json")
orig_mc = cs.make_console
def make_console(q):
    c = orig_mc(q)
    c.print = timed(c.print, "console.print")
    return c
cs.make_console = make_console
t = (time.perf_counter(), time.process_time())
try:
    cm.main(sys.argv[1:])
except SystemExit as e:
    code = e.code
T2 = (time.perf_counter(), time.process_time())
acc["cli main total"] = [T2[0]-t[0], T2[1]-t[1], 1]
acc["process total (after interpreter start)"] = [T2[0]-T0[0], T2[1]-T0[1], 1]
print(json.dumps({"code": code, "stages": acc, "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss/1024}), flush=True)
os._exit(0)
