"""Interleaved fresh-process runs: meshio read+write, the CLI of each src dir (with stage timing).
usage: python run.py OUTJSON REPEAT SRC1 [SRC2 ...]   (meshes in /tmp/io_b/1M.msh, 1M_ascii.msh)"""
import json, os, subprocess, sys, time, statistics
out, rep, srcs = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
D = os.environ.get("E2E_DIR", "/tmp/io_b")
HERE = os.path.dirname(os.path.abspath(__file__))
res = []
def run(cmd, env):
    t0 = time.perf_counter()
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=env)
    _, st, ru = os.wait4(p.pid, 0)
    wall = time.perf_counter() - t0
    o = p.stdout.read().decode().strip().splitlines()
    return wall, ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024, json.loads(o[-1]) if o else None
for r in range(rep):
    for enc, f in (("binary", "1M.msh"), ("ascii", "1M_ascii.msh")):
        env = dict(os.environ); env.pop("PYTHONPATH", None)
        w, c, rss, j = run([sys.executable, f"{HERE}/meshio_rw.py", f"{D}/{f}", f"{D}/meshio_{enc}.vtu"], env)
        res.append({"who": "meshio", "enc": enc, "rep": r, "wall": w, "cpu": c, "rss": rss, "detail": j})
        for s in srcs:
            env = dict(os.environ); env["PYTHONPATH"] = s
            tag = "new" if s.startswith("/work") else "base"
            w, c, rss, j = run([sys.executable, f"{HERE}/stages.py", f"{D}/{f}", f"{D}/out_{tag}_{enc}.vtu"], env)
            res.append({"who": s, "enc": enc, "rep": r, "wall": w, "cpu": c, "rss": rss, "detail": j})
        print(r, enc, [(x["who"][-12:], round(x["wall"], 2), round(x["cpu"], 2)) for x in res if x["rep"] == r and x["enc"] == enc], flush=True)
json.dump(res, open(out, "w"), indent=1)
