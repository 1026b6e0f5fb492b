"""Benchmark of omniloc.search.localize against the plain reading, brute force and RANSAC.

Run:  python benchmarks/run.py [--quick] [--scenes a,b,c,d] [--trials N]
                               [--out benchmarks/results.json]

Each scene group runs in its own subprocess, so ``ru_maxrss`` (the peak resident memory) is
per scene. Every localization has a budget (``timeout_s``) and every scene a wall-clock cap:
a trial that hits its budget is reported as timed out, never silently dropped. Writes the
JSON results, ``results.md`` (the Markdown tables, included verbatim in the README) and prints
the tables.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from baselines import brute_force, ransac  # noqa: E402
from omniloc.search import localize  # noqa: E402
from plain_reading import plain_localize  # noqa: E402
from scenes import CASES, GROUPS, LARGE, MAX_RANGE, build_map, make_trial  # noqa: E402

DEG = float(np.deg2rad(1.0))
POS_TOL, ANG_TOL = 0.1, DEG
#: An unambiguous answer is confidently wrong beyond these (the honest-answers tolerance).
WRONG_POS, WRONG_ANG = 0.3, 3 * DEG

#: Per group: trials (full, quick), per-localization budget (s), scene cap (s, full, quick).
CONFIG: dict[str, dict[str, Any]] = {
    "a": {"trials": (20, 3), "timeout": 5.0, "cap": (150.0, 30.0)},
    "b": {"trials": (10, 2), "timeout": 10.0, "cap": (300.0, 45.0)},
    "c": {"trials": (20, 2), "timeout": 10.0, "cap": (150.0, 30.0)},
    "cgrid": {"trials": (20, 2), "timeout": 10.0, "cap": (150.0, 30.0)},
    "d": {"trials": (4, 1), "timeout": 60.0, "cap": (300.0, 90.0)},
}
#: RANSAC iteration ladders searched for the count that matches omniloc's success rate.
RANSAC_LADDER = {
    "a": [250, 500, 1000, 2000, 4000, 8000, 16000, 32000],
    "b": [12_500, 25_000, 50_000, 100_000, 200_000, 400_000, 800_000, 1_600_000],
}
PLAIN_TIMEOUT = 60.0


def _ok(pose: Any, truth: Any) -> bool:
    if pose is None:
        return False
    d, dth = pose.distance_to(truth)
    return bool(d <= POS_TOL and dth <= ANG_TOL)


def _summ(times: list[float]) -> dict[str, float | None]:
    if not times:
        return {"median_ms": None, "p95_ms": None}
    t = np.asarray(times) * 1e3
    return {"median_ms": float(np.median(t)), "p95_ms": float(np.percentile(t, 95))}


# --------------------------------------------------------------------------------------------
# Worker: one scene group in its own process
# --------------------------------------------------------------------------------------------


def _run_localize(
    case: Any, trials: list[tuple[Any, Any]], timeout: float, deadline: float, **extra: Any
) -> dict[str, Any]:
    times, succ, complete, n_sol, nodes = [], 0, 0, [], []
    decisive = wrong = empty = 0
    for lm, sc in trials:
        if time.perf_counter() > deadline:
            break
        kw = {**case.kwargs, **extra}
        t0 = time.perf_counter()
        res = localize(lm, sc.bearings, timeout_s=timeout, **kw)
        times.append(time.perf_counter() - t0)
        succ += _ok(res.best.pose if res else None, sc.pose)
        complete += bool(res.stats.complete)
        n_sol.append(len(res))
        nodes.append(res.stats.nodes)
        empty += not res
        if not res.ambiguous:
            decisive += 1
            d, dth = res.best.pose.distance_to(sc.pose)
            wrong += bool(d > WRONG_POS or dth > WRONG_ANG)
    return {
        "trials": len(times),
        "planned": len(trials),
        "success": succ,
        "complete": complete,
        "decisive": decisive,
        "confidently_wrong": wrong,
        "empty": empty,
        "timeout_s": timeout,
        "median_solutions": float(np.median(n_sol)) if n_sol else None,
        "median_nodes": float(np.median(nodes)) if nodes else None,
        **_summ(times),
    }


def _memory(case: Any, trial: tuple[Any, Any], timeout: float) -> float:
    """tracemalloc peak (MiB) of one localization (numpy registers its buffers)."""
    lm, sc = trial
    tracemalloc.start()
    tracemalloc.reset_peak()
    localize(lm, sc.bearings, timeout_s=timeout, **case.kwargs)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def _ransac_rows(
    group: str,
    cases: list[Any],
    trials: dict[str, list[Any]],
    target: dict[str, int],
    deadline: float,
    quick: bool,
) -> list[dict[str, Any]]:
    """RANSAC at increasing iteration counts until it matches omniloc's success count."""
    rows = []
    for name in cases:
        case = CASES[name]
        gate = max(DEG, 3.0 * case.sigma)
        tr = trials[name]
        ladder = RANSAC_LADDER[group][:: 2 if quick else 1]
        tried = []
        for k in ladder:
            if time.perf_counter() > deadline:
                break
            times, succ = [], 0
            for i, (lm, sc) in enumerate(tr):
                out = ransac(
                    lm.xy,
                    sc.bearings,
                    gate=gate,
                    max_iter=k,
                    max_range=case.kwargs.get("max_range"),
                    rng=1000 + i,
                )
                times.append(out.elapsed_s)
                succ += _ok(out.pose, sc.pose)
            tried.append({"iterations": k, "success": succ, "trials": len(tr), **_summ(times)})
            if succ >= target[name]:
                break
        if not tried:
            continue
        match = next((t for t in tried if t["success"] >= target[name]), None)
        rows.append(
            {
                "method": "RANSAC",
                "case": name,
                "gate_deg": gate / DEG,
                "ladder": tried,
                "matched_omniloc": match is not None,
                **(match or tried[-1]),
            }
        )
    return rows


def worker(group: str, n_trials: int | None, quick: bool) -> dict[str, Any]:
    cfg = CONFIG[group]
    trials_n = n_trials or cfg["trials"][1 if quick else 0]
    timeout = cfg["timeout"]
    t_start = time.perf_counter()
    deadline = t_start + cfg["cap"][1 if quick else 0]
    t = time.perf_counter()
    lm = build_map(group)
    map_s = time.perf_counter() - t
    names = GROUPS[group]
    trials = {n: [make_trial(CASES[n], i, lm) for i in range(trials_n)] for n in names}
    # Warm-up: one call of every case (and its paper mode) before anything is timed, so
    # that no trial pays for numba compiling a kernel (a cold cache, as in a fresh clone or
    # after a kernel's source changed, took 41 s in the first a4n trial) or for a map's
    # neighbour lists.
    for name in names:
        lm0, sc0 = trials[name][0]
        localize(lm0, sc0.bearings, timeout_s=1.0, **CASES[name].kwargs)
        if group == "a":
            paper_kw = {**CASES[name].kwargs, "sigma": None}
            localize(lm0, sc0.bearings, timeout_s=1.0, method="paper", **paper_kw)
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    rows: list[dict[str, Any]] = []
    base: list[dict[str, Any]] = []
    n_cases = len(names)
    for j, name in enumerate(names):
        case = CASES[name]
        # Share the remaining time between the cases still to run.
        share = time.perf_counter() + (deadline - time.perf_counter()) * 0.6 / (n_cases - j)
        row: dict[str, Any] = {"case": name, "group": group, "label": case.label}
        row["n_landmarks"] = int(trials[name][0][0].n)
        row["n_obs"] = float(np.median([sc.bearings.size for _, sc in trials[name]]))
        row["robust"] = _run_localize(case, trials[name], timeout, share)
        if group == "a":
            row["paper"] = _run_localize(
                case,
                trials[name],
                timeout,
                share,
                method="paper",
                **({"sigma": None} if case.sigma else {}),
            )
        row["tracemalloc_peak_mib"] = _memory(case, trials[name][0], timeout)
        rows.append(row)
    rss1 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for row in rows:
        row["maxrss_delta_mib"] = (rss1 - rss0) / 1024.0
        row["maxrss_mib"] = rss1 / 1024.0
    # ---- baselines -------------------------------------------------------------------------
    if group == "b":
        for name in names:
            base.append(
                {
                    "method": "plain reading",
                    "case": name,
                    "skipped": "no wildcards: 3 spurious bearings leave it no complete path",
                }
            )
    if group == "a":
        for name in names:
            if time.perf_counter() > deadline:
                base.append({"method": "plain reading", "case": name, "skipped": "scene cap"})
                continue
            k = min(len(trials[name]), 5)
            times, succ, done = [], 0, 0
            for lm_i, sc in trials[name][:k]:
                thr = DEG
                tmo = min(PLAIN_TIMEOUT, max(1.0, deadline - time.perf_counter()))
                sols, st = plain_localize(lm_i.xy, sc.bearings, thr, timeout_s=tmo)
                times.append(st["elapsed_s"])
                done += bool(st["complete"])
                best = _plain_best(lm_i.xy, sc.bearings, sols)
                succ += _ok(best, sc.pose)
            base.append(
                {
                    "method": "plain reading",
                    "case": name,
                    "trials": len(times),
                    "complete": done,
                    "success": succ,
                    "timeout_s": PLAIN_TIMEOUT,
                    **_summ(times),
                }
            )
    if group == "a":
        for name in names:
            case = CASES[name]
            if math.perm(12, case.m) > 2_000_000 or time.perf_counter() > deadline:
                base.append(
                    {
                        "method": "brute force",
                        "case": name,
                        "skipped": f"{math.perm(12, case.m)} paths > 2e6"
                        if math.perm(12, case.m) > 2_000_000
                        else "scene cap",
                    }
                )
                continue
            times, succ = [], 0
            for lm_i, sc in trials[name][:3]:
                sols, st = brute_force(lm_i.xy, sc.bearings, DEG)
                times.append(st["elapsed_s"])
                succ += _ok(_plain_best(lm_i.xy, sc.bearings, sols), sc.pose)
            base.append(
                {
                    "method": "brute force",
                    "case": name,
                    "trials": len(times),
                    "success": succ,
                    "paths": math.perm(12, case.m),
                    **_summ(times),
                }
            )
    if group == "b":
        for name in names:
            base.append(
                {
                    "method": "brute force",
                    "case": name,
                    "skipped": f"{math.perm(30, 10):.2e} paths > 2e6",
                }
            )
    if group in ("a", "b"):
        target = {r["case"]: r["robust"]["success"] for r in rows}
        todo = [n for n in names if n in ("a7", "a7n", "b")]
        base += _ransac_rows(group, todo, trials, target, deadline, quick)
    if group == "c":
        n = LARGE[group][0]
        sc = trials[names[0]][0][1]
        m = sc.bearings.size
        w = (m - sc.n_spurious) / m
        p_good = w**3 / (n * (n - 1) * (n - 2))
        need = math.log(0.01) / math.log1p(-p_good)
        tmo = max(1.0, min(5.0, deadline - time.perf_counter()))
        out = ransac(
            trials[names[0]][0][0].xy,
            sc.bearings,
            gate=max(DEG, 3 * CASES["c"].sigma),
            max_iter=10**9,
            max_range=MAX_RANGE,
            timeout_s=tmo,
            rng=0,
        )
        base.append(
            {
                "method": "RANSAC",
                "case": names[0],
                "trials": 1,
                "success": int(_ok(out.pose, sc.pose)),
                "iterations": out.iterations,
                "median_ms": out.elapsed_s * 1e3,
                "p95_ms": out.elapsed_s * 1e3,
                "timeout_s": tmo,
                "iterations_for_99pct": need,
                "note": f"timed out after {tmo:.0f} s; 99 % needs ~{need:.1e} iterations",
            }
        )
    return {
        "group": group,
        "map_build_s": map_s,
        "rows": rows,
        "baselines": base,
        "wall_s": time.perf_counter() - t_start,
    }


def _plain_best(xy: np.ndarray, bearings: np.ndarray, sols: list[Any]) -> Any:
    """The best of a list of (assignment, pose): lowest RMS bearing residual."""
    if not sols:
        return None
    from omniloc.pose import predict_bearings

    def rms(item: Any) -> float:
        a, p = item
        r = np.angle(np.exp(1j * (predict_bearings(xy[list(a)], p) - bearings)))
        return float(np.sqrt(np.mean(r * r)))

    return min(sols, key=rms)[1]


# --------------------------------------------------------------------------------------------
# Parent: subprocesses, tables, targets
# --------------------------------------------------------------------------------------------


def _machine() -> dict[str, Any]:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    import omniloc

    try:
        import os

        ncpu = len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        ncpu = None
    return {
        "cpu": cpu,
        "cpus_available": ncpu,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "omniloc": omniloc.__version__,
        "platform": platform.platform(),
        "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }


def _fmt_ms(v: float | None) -> str:
    if v is None:
        return "-"
    return f"{v:.3g}" if v < 100 else f"{v:.0f}"


def _rate(s: int, n: int) -> str:
    return f"{s}/{n}" + (f" ({100.0 * s / n:.0f} %)" if n else "")


def _cell(r: dict[str, Any]) -> tuple[str, str, str]:
    """median, p95 and a note on timeouts for one omniloc measurement."""
    note = ""
    if r["trials"] < r["planned"]:
        note = f"scene cap: {r['trials']}/{r['planned']} trials run; "
    if r["complete"] < r["trials"]:
        note += (
            f"timed out after {r['timeout_s']:.0f} s: {r['trials'] - r['complete']}/"
            f"{r['trials']} trials"
        )
    return _fmt_ms(r["median_ms"]), _fmt_ms(r["p95_ms"]), note.rstrip("; ")


def targets(groups: dict[str, Any]) -> list[dict[str, str]]:
    """Evaluate the targets from the measurements."""
    out = []
    rows = {r["case"]: r for g in groups.values() for r in g["rows"]}
    base = [b for g in groups.values() for b in g["baselines"]]

    def plain(case: str) -> dict[str, Any] | None:
        return next(
            (
                b
                for b in base
                if b["method"] == "plain reading" and b["case"] == case and "median_ms" in b
            ),
            None,
        )

    for case in ("a7", "a7n"):
        if case not in rows:
            continue
        r, p = rows[case], plain(case)
        med, pap = r["robust"]["median_ms"], r["paper"]["median_ms"]
        sp_paper = p["median_ms"] / pap if p and pap else None
        sp_robust = p["median_ms"] / med if p and med else None
        ok = med is not None and med <= 1.0 and sp_robust is not None and sp_robust >= 100
        out.append(
            {
                "scene": case,
                "target": "median <= 1 ms (7 obs) and >= 100x faster than the plain reading",
                "measured": f"median {_fmt_ms(med)} ms (paper mode {_fmt_ms(pap)} ms); plain "
                f"{_fmt_ms(p['median_ms']) if p else '-'} ms: speed-up "
                f"{sp_robust or 0:.0f}x (paper mode {sp_paper or 0:.0f}x)",
                "status": "met" if ok else "missed",
            }
        )
    if "b" in rows:
        r = rows["b"]["robust"]
        rs = next((b for b in base if b["method"] == "RANSAC" and b["case"] == "b"), None)
        faster = (
            rs is not None
            and r["median_ms"] is not None
            and rs.get("median_ms") is not None
            and r["median_ms"] < rs["median_ms"]
        )
        eq = rs is not None and rs.get("matched_omniloc", False)
        ok = r["median_ms"] is not None and r["median_ms"] <= 10 and faster and eq
        rs_txt = (
            (
                f"RANSAC {_fmt_ms(rs['median_ms'])} ms at {rs['iterations']} iterations, "
                f"success {_rate(rs['success'], rs['trials'])}"
                + ("" if eq else " (never reached omniloc's success)")
            )
            if rs
            else "RANSAC -"
        )
        out.append(
            {
                "scene": "b",
                "target": "median <= 10 ms, faster than RANSAC at equal success",
                "measured": f"median {_fmt_ms(r['median_ms'])} ms, success "
                f"{_rate(r['success'], r['trials'])}, complete {r['complete']}/"
                f"{r['trials']}; {rs_txt}",
                "status": "met" if ok else "missed",
            }
        )
    for case in ("c", "c-default", "cgrid", "cgrid-default"):
        if case not in rows:
            continue
        r = rows[case]["robust"]
        ok = (
            r["median_ms"] is not None
            and r["median_ms"] <= 250
            and r["trials"]
            and r["success"] / r["trials"] >= 0.99
            and r["complete"] == r["trials"]
            and r.get("confidently_wrong", 0) == 0
        )
        out.append(
            {
                "scene": case,
                "target": "median <= 250 ms with success >= 99 %, never confidently wrong"
                + (" (localize's default options)" if case.endswith("default") else ""),
                "measured": f"median {_fmt_ms(r['median_ms'])} ms, success "
                f"{_rate(r['success'], r['trials'])}, complete {r['complete']}/"
                f"{r['trials']} (budget {r['timeout_s']:.0f} s), decisive / confidently "
                f"wrong {_honesty(r)}",
                "status": "met" if ok else "missed",
            }
        )
    if "d" in rows:
        r = rows["d"]["robust"]
        # The whole process at its peak: Python, numba, the map, its k-d tree and neighbour
        # lists (built in the warm-up call) and every localization.
        mem = rows["d"]["maxrss_mib"]
        c = rows.get("c")
        lin = None
        if c and c["robust"]["median_ms"] and r["median_ms"] is not None:
            lin = r["median_ms"] / c["robust"]["median_ms"]
        timed_out = r["complete"] < r["trials"] or (
            c and c["robust"]["complete"] < c["robust"]["trials"]
        )
        ok = lin is not None and lin <= 10.0 and mem <= 1024 and not timed_out
        out.append(
            {
                "scene": "d",
                "target": "time (d)/(c) <= 100,000/10,000 = 10 (linear), peak memory <= 1 GiB",
                "measured": f"median {_fmt_ms(r['median_ms'])} ms, ratio d/c "
                f"{'-' if lin is None else f'{lin:.2f}'}"
                + (" (not meaningful: trials timed out)" if timed_out else "")
                + f"; peak memory of the process {mem:.0f} MiB; complete "
                f"{r['complete']}/{r['trials']}",
                "status": "met"
                if ok
                else ("not measurable (timeouts)" if timed_out and mem <= 1024 else "missed"),
            }
        )
    return out


def _honesty(r: dict[str, Any]) -> str:
    """'decisive / confidently wrong' counts of a row (older results files have neither)."""
    if "decisive" not in r:
        return "-"
    return f"{r['decisive']} / {r['confidently_wrong']}"


def markdown(result: dict[str, Any]) -> str:
    m = result["machine"]
    lines = [
        f"Measured {m['date']} on {m['cpu']} ({m['cpus_available']} CPUs available), "
        f"Python {m['python']}, numpy {m['numpy']}, omniloc {m['omniloc']}"
        + (" -- **quick run**" if result["quick"] else "")
        + ".",
        "",
        '**omniloc `localize` (default `method="robust"`)**; success = best solution within '
        "0.1 m and 1 deg of the truth.",
        "",
        "| scene | N | obs | trials | median ms | p95 ms | success | decisive / confidently "
        "wrong | tracemalloc peak MiB | maxrss delta MiB | paper-mode median ms | notes |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for g in result["groups"].values():
        for r in g["rows"]:
            rb = r["robust"]
            med, p95, note = _cell(rb)
            pm = _fmt_ms(r["paper"]["median_ms"]) if "paper" in r else "-"
            lines.append(
                f"| {r['case']}: {r['label']} | {r['n_landmarks']} | {r['n_obs']:.0f} "
                f"| {rb['trials']} | {med} | {p95} | {_rate(rb['success'], rb['trials'])} "
                f"| {_honesty(rb)} | {r['tracemalloc_peak_mib']:.1f} "
                f"| {r['maxrss_delta_mib']:.1f} | {pm} | {note} |"
            )
    lines += [
        "",
        "**Baselines** (same trials as above, first k of them)",
        "",
        "| method | scene | trials | median ms | p95 ms | success | notes |",
        "|---|---|---|---|---|---|---|",
    ]
    for g in result["groups"].values():
        for b in g["baselines"]:
            if "skipped" in b:
                lines.append(
                    f"| {b['method']} | {b['case']} | 0 | - | - | - | not run: {b['skipped']} |"
                )
                continue
            note = b.get("note", "")
            if b["method"] == "plain reading" and b["complete"] < b["trials"]:
                note = (
                    f"timed out after {b['timeout_s']:.0f} s: "
                    f"{b['trials'] - b['complete']}/{b['trials']} trials"
                )
            if b["method"] == "brute force":
                note = f"{b['paths']} paths checked"
            if b["method"] == "RANSAC" and "ladder" in b:
                note = (
                    f"{b['iterations']} iterations, gate {b['gate_deg']:.1f} deg; "
                    + ("matches" if b["matched_omniloc"] else "never reached")
                    + " omniloc's success; ladder: "
                    + ", ".join(
                        f"{t['iterations']}: {t['success']}/{t['trials']}" for t in b["ladder"]
                    )
                )
            lines.append(
                f"| {b['method']} | {b['case']} | {b['trials']} "
                f"| {_fmt_ms(b.get('median_ms'))} | {_fmt_ms(b.get('p95_ms'))} "
                f"| {_rate(b['success'], b['trials'])} | {note} |"
            )
    lines += ["", "**Targets**", "", "| scene | target | measured | status |", "|---|---|---|---|"]
    for t in result["targets"]:
        lines.append(f"| {t['scene']} | {t['target']} | {t['measured']} | {t['status']} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short smoke run")
    ap.add_argument(
        "--scenes", default="a,b,c,cgrid,d", help="comma-separated subset of a,b,c,cgrid,d"
    )
    ap.add_argument("--trials", type=int, default=None, help="trials per scene (override)")
    ap.add_argument(
        "--out",
        type=Path,
        default=None,
        help="results file (default benchmarks/results.json, results-quick.json "
        "with --quick); the Markdown tables go beside it as .md",
    )
    ap.add_argument(
        "--render",
        action="store_true",
        help="measure nothing: re-evaluate the targets of an existing results file and "
        "rewrite its tables",
    )
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--worker-out", type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.render:
        path = args.out or HERE / ("results-quick.json" if args.quick else "results.json")
        result = json.loads(path.read_text())
        result["targets"] = targets(result["groups"])
        path.write_text(json.dumps(result, indent=1))
        path.with_suffix(".md").write_text(markdown(result))
        print(markdown(result))
        return 0
    if args.worker:
        res = worker(args.worker, args.trials, args.quick)
        args.worker_out.write_text(json.dumps(res))
        return 0
    groups = [g.strip() for g in args.scenes.split(",") if g.strip()]
    bad = [g for g in groups if g not in CONFIG]
    if bad:
        ap.error(f"unknown scene(s) {bad}; choose from {','.join(CONFIG)}")
    result: dict[str, Any] = {
        "machine": _machine(),
        "quick": args.quick,
        "groups": {},
        "success_definition": "best solution within 0.1 m and 1 deg",
    }
    for g in groups:
        cap = CONFIG[g]["cap"][1 if args.quick else 0]
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "w.json"
            cmd = [sys.executable, __file__, "--worker", g, "--worker-out", str(out)]
            if args.trials:
                cmd += ["--trials", str(args.trials)]
            if args.quick:
                cmd.append("--quick")
            t0 = time.perf_counter()
            print(f"scene {g} ...", file=sys.stderr, flush=True)
            try:
                subprocess.run(cmd, check=True, timeout=cap * 2 + 120)
                result["groups"][g] = json.loads(out.read_text())
            except (subprocess.TimeoutExpired, subprocess.CalledProcessError) as exc:
                print(f"scene {g} failed: {exc}", file=sys.stderr)
                result["groups"][g] = {"group": g, "rows": [], "baselines": [], "error": str(exc)}
            print(f"scene {g} done in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    result["targets"] = targets(result["groups"])
    md = markdown(result)
    if args.out is None:
        args.out = HERE / ("results-quick.json" if args.quick else "results.json")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=1))
    args.out.with_suffix(".md").write_text(md)
    print(md)
    return 0


if __name__ == "__main__":
    sys.exit(main())
