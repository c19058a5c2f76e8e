"""Issue 17's targets against the rows of one ``bench_speed.py`` run: one line per target and mesh, with the
measured value, the target and the distance to it ("met" or how far off).  It states, it asserts nothing.

A target is stated for the mesh the issue names it for (end to end / meshio, set-up, peak RSS at 1M, cold -
warm at 200k), the compiled / numpy pass on a busy machine for every mesh; the quantity is printed for the
other meshes of the run too, without a target (``-``).
"""

from __future__ import annotations

#: (what, the mesh the absolute target is for or None for a ratio, limit, unit)
TARGETS = (
    ("CLI binary msh / meshio", "1M", 2.0, "x"),
    ("CLI ascii msh / meshio", "1M", 2.5, "x"),
    ("set-up (topology + floors)", "1M", 1.0, "s"),
    ("set-up (topology + floors)", "quad1M", 2.0, "s"),
    ("CLI peak RSS, binary msh", "1M", 600.0, "MB"),
    ("CLI cold - warm cache", "200k", 5.0, "s"),
    ("loaded: numba / numpy pass", None, 1.0, "x"),
)


def _default_angle(rows: list[dict], mesh: str, loaded: bool = False, kernel: str | None = None) -> dict | None:
    """The guarded ``angle`` row of ``mesh`` (automatic threads for a loaded one), preferring ``kernel``."""
    name = "angle (loaded)" if loaded else "angle"
    hits = [r for r in rows if r.get("mesh") == mesh and r.get("method") == name and r.get("guard")
            and "error" not in r and (not loaded or r.get("kernel") == "numpy" or r.get("threads_asked", 0) == 0)]
    if kernel is not None:
        hits = [r for r in hits if r.get("kernel") == kernel]
    elif any(r.get("kernel") == "numba" for r in hits):  # what the default install runs on a large mesh
        hits = [r for r in hits if r.get("kernel") == "numba"]
    return hits[0] if hits else None


def measured(rows: list[dict]) -> list[tuple[str, str, float]]:
    """(what, mesh, value) of every target quantity the rows hold."""
    out = []
    meshes = list(dict.fromkeys(r["mesh"] for r in rows if "mesh" in r))
    for mesh in meshes:
        for enc in ("binary", "ascii"):
            cli = [r for r in rows if r.get("mesh") == mesh and r.get("method") == f"CLI ({enc} msh)"]
            if cli and cli[0].get("ratio_to_meshio"):
                out.append((f"CLI {enc} msh / meshio", mesh, cli[0]["ratio_to_meshio"]))
            if enc == "binary" and cli and cli[0].get("peak_rss_mb"):
                out.append(("CLI peak RSS, binary msh", mesh, cli[0]["peak_rss_mb"]))
        r = _default_angle(rows, mesh)
        if r is not None and r.get("setup_s") is not None:
            out.append(("set-up (topology + floors)", mesh, r["setup_s"] + (r.get("floors_s") or 0.0)))
        fast, slow = _default_angle(rows, mesh, True, "numba"), _default_angle(rows, mesh, True, "numpy")
        if fast and slow and fast.get("pass_s") and slow.get("pass_s"):
            out.append(("loaded: numba / numpy pass", mesh, fast["pass_s"] / slow["pass_s"]))
        cold = {r["state"]: r.get("e2e_s") for r in rows
                if r.get("mesh") == mesh and "state" in r and r.get("method", "").startswith("CLI")}
        if cold.get("cold") is not None and cold.get("warm") is not None:
            out.append(("CLI cold - warm cache", mesh, cold["cold"] - cold["warm"]))
    return out


def targets_table(rows: list[dict]) -> str:
    head = f"{'target':<28} {'mesh':>9} {'measured':>9} {'target':>9}  distance"
    lines = ["issue 17's targets: measured in this run (each target for the mesh the issue names; '-': no",
             "target at this size)", head, "-" * len(head)]
    for what, mesh, value in measured(rows):
        limit = unit = None
        for t_what, t_mesh, t_limit, t_unit in TARGETS:
            if t_what == what and t_mesh in (None, mesh):
                limit, unit = t_limit, t_unit
        unit = unit or next(u for w, _, _, u in TARGETS if w == what)
        shown = f"{value:.0f} MB" if unit == "MB" else f"{value:.2f}{'x' if unit == 'x' else ' ' + unit}"
        if limit is None:
            verdict, goal = "-", "-"
        else:
            goal = f"{limit:g}x" if unit == "x" else f"{limit:g} {unit}"
            verdict = "met" if value <= limit else (
                f"{value / limit:.2f}x the target" if unit == "x" else f"{value - limit:+.2f} {unit} over")
        lines.append(f"{what:<28} {mesh:>9} {shown:>9} {goal:>9}  {verdict}")
    return "\n".join(lines)
