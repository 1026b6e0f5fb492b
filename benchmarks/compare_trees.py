"""Time two checkouts of omniloc against each other on the benchmark scenes, interleaved.

Run:  python benchmarks/compare_trees.py BEFORE_TREE AFTER_TREE [a7=20 b=10 ...]

Each tree (a checkout with ``src/`` and ``benchmarks/``) runs in its own worker process with
its own ``src`` on the path and its own ``benchmarks/scenes.py``; the two are asked for the
same trial in alternating order, so that the machine's changing speed hits both alike. Prints,
per scene, the median time of each, the median of the per-trial ratios and the success
counts (best within 0.1 m). A scene that a tree's ``scenes.py`` does not know fails that
worker. Used for the comparison in the README's Speed section (before = commit 6833510).
"""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

#: Trials per scene. d takes the benchmark's four: with two, the median of the per-trial ratios
#: is their mean, and its trial 1 (a first fit that searches on: 1.56x the nodes since the
#: posterior's stop rule; trials 0, 2 and 3 visit the same nodes as before) set it alone.
DEFAULT_TRIALS = {"a4": 10, "a7": 20, "a4n": 10, "a7n": 20, "b": 10, "b360": 4, "c": 8, "d": 4}

WORKER = """
import json, sys, time
tree = sys.argv[1]
sys.path.insert(0, tree + "/benchmarks")
from omniloc.search import localize
from scenes import CASES, build_map, make_trial
maps = {}
warm = set()
for line in sys.stdin:
    name, i = line.split()
    case = CASES[name]
    if case.group not in maps:
        maps[case.group] = build_map(case.group)
    lm, sc = make_trial(case, int(i), maps[case.group])
    if name not in warm:
        # Untimed first call of each scene: no trial pays for compiling (a cold cache).
        localize(lm, sc.bearings, timeout_s=1.0, **case.kwargs)
        warm.add(name)
    t0 = time.perf_counter()
    r = localize(lm, sc.bearings, **case.kwargs)
    dt = time.perf_counter() - t0
    ok = r.best is not None and r.best.pose.distance_to(sc.pose)[0] <= 0.1
    print(json.dumps([dt, bool(ok)]), flush=True)
"""


def _worker(tree: Path) -> subprocess.Popen[str]:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"), MPLBACKEND="Agg")
    return subprocess.Popen(
        [sys.executable, "-c", WORKER, str(tree)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env=env,
        cwd=tree,
    )


def _ask(p: subprocess.Popen[str], name: str, i: int) -> list[float]:
    assert p.stdin is not None and p.stdout is not None
    p.stdin.write(f"{name} {i}\n")
    p.stdin.flush()
    line = p.stdout.readline()
    if not line:
        raise SystemExit(f"a worker failed on scene {name} (does its scenes.py know it?)")
    return list(json.loads(line))


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__)
        return 2
    before, after = Path(argv[0]).resolve(), Path(argv[1]).resolve()
    trials = dict(DEFAULT_TRIALS)
    if argv[2:]:
        trials = {k: int(v) for k, v in (a.split("=") for a in argv[2:])}
    a, b = _worker(before), _worker(after)
    for name, n in trials.items():
        _ask(a, name, 0)  # warm-up: compilation, the map
        _ask(b, name, 0)
        ta, tb, sa, sb = [], [], 0, 0
        for i in range(n):
            order = (a, b) if i % 2 == 0 else (b, a)
            res = {id(p): _ask(p, name, i) for p in order}
            ta.append(res[id(a)][0])
            tb.append(res[id(b)][0])
            sa += int(res[id(a)][1])
            sb += int(res[id(b)][1])
        ratio = statistics.median(y / x for x, y in zip(ta, tb, strict=True))
        print(
            f"{name:5s} before {statistics.median(ta) * 1e3:9.2f} ms  after "
            f"{statistics.median(tb) * 1e3:9.2f} ms  after/before {ratio:.3f}  "
            f"success {sa}/{n} vs {sb}/{n}",
            flush=True,
        )
    for p in (a, b):
        assert p.stdin is not None
        p.stdin.close()
        p.wait()
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
