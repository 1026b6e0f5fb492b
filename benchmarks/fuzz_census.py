"""Census of bad and extreme input: every value of every pool of ``tests/_fuzz.py`` against its
public function or subcommand, one case at a time, each judged ok / refused / bad / hang.

Usage::

    python benchmarks/fuzz_census.py [--src DIR] [--limit S] [--json OUT] [--only NAME ...]

``--src`` is the ``src`` folder of the omniloc to judge (default: this checkout's), so the same
cases can be counted on an older commit (``git archive <rev> src | tar -x -C /tmp/old``).
Cases run in a worker process that is killed and restarted when a case takes longer than
``--limit`` seconds (a *hang*; default 20 s, the issue's measure); warnings are errors there,
as under pytest. The judgement is that of the fuzz suite (:mod:`_fuzz`).
"""

from __future__ import annotations

import argparse
import json
import os
import select
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

HERE = Path(__file__).resolve().parent
TESTS = HERE.parent / "tests"


def cases(only: list[str]) -> list[tuple[str, str, str, str]]:
    """Every (kind, target, argument, label), in a fixed order."""
    sys.path.insert(0, str(TESTS))
    import _fuzz as F

    out = []
    for name, t in F.all_targets().items():
        if only and name not in only:
            continue
        for arg, a in t.args.items():
            out += [("fn", name, arg, label) for label, _ in a.pool]
    for name, c in F.cli_targets().items():
        if only and f"cli {name}" not in only:
            continue
        for opt, pool in c.options.items():
            out += [("cli", name, opt, label) for label, _ in pool]
    return out


def worker() -> None:
    """Read cases as JSON lines on stdin, answer each with a JSON line on stdout."""
    import tempfile
    import warnings

    sys.path.insert(0, str(TESTS))
    warnings.simplefilter("error")
    import _fuzz as F

    fns, clis = F.all_targets(), F.cli_targets()
    # Whatever a case writes to a relative path lands in a scratch folder, not the checkout.
    scratch = tempfile.TemporaryDirectory()
    os.chdir(scratch.name)
    real_stdout = os.fdopen(os.dup(1), "w")
    # Load (or compile) the kernels before the first case, so that no case pays for it.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import omniloc

        omniloc.localize(F.room(), F.z5())
        omniloc.localize(F.room(), F.z5(), sigma=0.01, max_spurious=1)
    real_stdout.write("ready\n")
    real_stdout.flush()
    for line in sys.stdin:
        kind, name, arg, label = json.loads(line)
        with tempfile.TemporaryDirectory() as d:
            folder = Path(d)
            if kind == "fn":
                t = fns[name]
                value = dict(t.args[arg].pool)[label]
                o = F.run_target(t, arg, value, folder)
            else:
                c = clis[name]
                value = dict(c.options[arg])[label]
                o = F.judge_cli(F.cli_argv(c, arg, value, folder), folder, limit_s=c.limit_s)
        real_stdout.write(json.dumps([o.kind, o.detail[:300], o.elapsed]) + "\n")
        real_stdout.flush()


def _commit(src: Path) -> str:
    """The git commit of ``src`` (with ``+`` when its tree has changes), or ""."""
    git = ["git", "-C", str(src)]
    try:
        head = subprocess.run(
            [*git, "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True
        ).stdout.strip()
        dirty = subprocess.run([*git, "status", "--porcelain", "."], capture_output=True, text=True)
    except (OSError, subprocess.CalledProcessError):
        return ""
    return head + ("+" if dirty.stdout.strip() else "")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--src", type=Path, default=HERE.parent / "src")
    ap.add_argument("--limit", type=float, default=20.0, help="seconds before a case is a hang")
    ap.add_argument(
        "--json",
        type=Path,
        default=HERE / "results_fuzz.json",
        help="write the census and each bad case here (default: %(default)s)",
    )
    ap.add_argument("--only", nargs="*", default=[], help="target names ('cli localize' ...)")
    ap.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        worker()
        return 0
    todo = cases(args.only)
    env = dict(os.environ, PYTHONPATH=str(args.src.resolve()), MPLBACKEND="Agg")
    cmd = [sys.executable, __file__, "--worker"]
    proc: subprocess.Popen[str] | None = None
    results = []
    tally: Counter[str] = Counter()
    by_target: dict[str, Counter[str]] = {}
    t0 = time.perf_counter()
    for case in todo:
        if proc is None:
            proc = subprocess.Popen(
                cmd,
                env=env,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.DEVNULL,
                text=True,
                bufsize=1,
            )
            assert proc.stdout is not None
            ready, _, _ = select.select([proc.stdout], [], [], 600.0)
            if not ready or proc.stdout.readline().strip() != "ready":
                print("the worker did not start", file=sys.stderr)
                return 2
        assert proc.stdin is not None and proc.stdout is not None
        proc.stdin.write(json.dumps(case) + "\n")
        proc.stdin.flush()
        limit = args.limit
        ready, _, _ = select.select([proc.stdout], [], [], limit)
        line = proc.stdout.readline() if ready else ""
        if line:
            kind, detail, dt = json.loads(line)
        else:
            kind, detail, dt = "hang", f"no answer in {limit:g} s (or the worker died)", limit
            proc.kill()
            proc.wait()
            proc = None
        tally[kind] += 1
        by_target.setdefault(f"{case[0]} {case[1]}", Counter())[kind] += 1
        results.append({"case": case, "outcome": kind, "detail": detail, "seconds": dt})
        if kind in ("bad", "hang"):
            print(f"{kind.upper():5s} {case[1]}({case[2]}={case[3]}): {detail}", flush=True)
    if proc is not None:
        proc.kill()
        proc.wait()
    print()
    for name, c in sorted(by_target.items()):
        print(f"  {name:28s} " + "  ".join(f"{k} {c[k]}" for k in ("ok", "refused", "bad", "hang")))
    total = sum(tally.values())
    print(
        f"\n{total} cases in {time.perf_counter() - t0:.0f} s: ok {tally['ok']}, refused "
        f"{tally['refused']}, bad {tally['bad']}, hang {tally['hang']}"
    )
    census = {
        "src": str(args.src.resolve()),
        "commit": _commit(args.src),
        "limit_s": args.limit,
        "cases": total,
        "tally": {k: tally[k] for k in ("ok", "refused", "bad", "hang")},
        "by_target": {k: dict(v) for k, v in sorted(by_target.items())},
        # every case that ended badly, with why; the others only as counts above
        "bad": [r for r in results if r["outcome"] in ("bad", "hang")],
    }
    args.json.write_text(json.dumps(census, indent=1) + "\n")
    print(f"written to {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
