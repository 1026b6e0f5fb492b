"""How much the ordering constraint prunes, next to the paper's rules alone.

For each setting, the same seeded scenes are localized with and without ``ordering=True``;
the table gives the nodes visited, the paths examined beyond depth three, the nodes the
ordering test cut, the number of solutions, and how often the true pose is still among them.
Run: ``python benchmarks/ordering.py`` (writes ``benchmarks/results_ordering.json``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from omniloc.search import localize
from omniloc.simulate import demo_room, observe, random_map, random_pose

SETTINGS = [
    # (label, map maker, observations, noise deg, gate options)
    ("demo room, 6 obs, threshold 1 deg", "room", 6, 0.2, {"threshold": np.deg2rad(1.0)}),
    ("demo room, 6 obs, threshold 5 deg", "room", 6, 0.2, {"threshold": np.deg2rad(5.0)}),
    ("demo room, 6 obs, sigma 0.5 deg", "room", 6, 0.5, {"sigma": np.deg2rad(0.5)}),
    ("20 random, 7 obs, sigma 0.5 deg", "random20", 7, 0.5, {"sigma": np.deg2rad(0.5)}),
    ("20 random, 7 obs, sigma 2 deg", "random20", 7, 2.0, {"sigma": np.deg2rad(2.0)}),
]


def run(trials: int, seed: int) -> list[dict[str, object]]:
    rows = []
    for label, kind, m, noise, opts in SETTINGS:
        rng = np.random.default_rng(seed)
        acc = {"plain": np.zeros(4), "ordering": np.zeros(4)}
        cut = 0
        for _ in range(trials):
            lm = demo_room() if kind == "room" else random_map(20, rng=rng)
            pose = random_pose(lm, rng=rng)
            sc = observe(lm, pose, n_obs=m, sigma=np.deg2rad(noise), rng=rng)
            for name, flag in (("plain", False), ("ordering", True)):
                # The tree: it prunes by the ordering at every node (the hypotheses strategy
                # only checks complete interpretations).
                r = localize(lm, sc.bearings, ordering=flag, strategy="tree", **opts)
                truth = any(
                    s.pose.distance_to(pose)[0] < 0.2 and s.pose.distance_to(pose)[1] < 0.05
                    for s in r.solutions
                )
                acc[name] += [r.stats.nodes, r.stats.examined_paths, len(r), truth]
                if flag:
                    cut += r.stats.pruned_ordering
        p, o = acc["plain"] / trials, acc["ordering"] / trials
        rows.append(
            {
                "setting": label,
                "trials": trials,
                "nodes_plain": p[0],
                "nodes_ordering": o[0],
                "examined_plain": p[1],
                "examined_ordering": o[1],
                "pruned_by_ordering_per_search": cut / trials,
                "solutions_plain": p[2],
                "solutions_ordering": o[2],
                "truth_found_plain": p[3],
                "truth_found_ordering": o[3],
            }
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=30)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path, default=Path(__file__).with_name("results_ordering.json"))
    args = ap.parse_args()
    rows = run(args.trials, args.seed)
    print(
        "| setting | nodes (paper rules) | nodes (+ ordering) | cut by ordering | "
        "solutions | solutions (+ ordering) | truth found | truth found (+ ordering) |"
    )
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(
            f"| {r['setting']} | {r['nodes_plain']:.0f} | {r['nodes_ordering']:.0f} | "
            f"{r['pruned_by_ordering_per_search']:.1f} | {r['solutions_plain']:.2f} | "
            f"{r['solutions_ordering']:.2f} | {100 * r['truth_found_plain']:.0f} % | "
            f"{100 * r['truth_found_ordering']:.0f} % |"
        )
    args.out.write_text(
        json.dumps({"trials": args.trials, "seed": args.seed, "rows": rows}, indent=2) + "\n"
    )
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
