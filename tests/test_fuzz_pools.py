"""Every bad or extreme value of the pools in ``_fuzz.py``, against its public function and its
subcommand, one case each: only omniloc's own errors, on one line and naming the argument;
sane results otherwise; no call beyond its time (see ``_fuzz`` for the judgement).

The issue's whole-call reproducers (hangs, memory, silent answers) are in
``test_fuzz_scenarios.py``; generated values in ``test_fuzz_generated.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

import _fuzz as F

#: (Timed calls: the kernels are compiled before the first, not during it.)
pytestmark = pytest.mark.usefixtures("compiled_kernels")

TARGETS = F.all_targets()
CLI = F.cli_targets()

#: Targets with tests of their own (whole calls of several seconds, with their own bounds).
OWN_TESTS = {"scenario"}

#: Targets whose every case costs a figure or a sweep (0.3-1.5 s): CI runs every k-th of
#: their cases (a fixed choice), ``benchmarks/fuzz_census.py`` all of them.
THINNED = {"plot_localization": 3, "unwrap_panorama": 2, "render_omni_image": 2, "evaluate": 4}

#: Cases known to fail, as (target, argument, label): strict, so a fix makes the case pass
#: and then it must leave this set.
KNOWN_BAD: set[tuple[str, str, str]] = set()


def _params(name: str, cases: list[tuple[str, str]]) -> list[Any]:
    k = THINNED.get(name, 1)
    out = []
    for i, (arg, label) in enumerate(cases):
        if i % k:
            continue
        marks = []
        if (name, arg, label) in KNOWN_BAD:
            marks = [pytest.mark.xfail(strict=True, reason="known bad case")]
        out.append(pytest.param(name, arg, label, id=f"{name}-{arg}-{label}", marks=marks))
    return out


CASES = [
    p
    for name, t in TARGETS.items()
    if name not in OWN_TESTS
    for p in _params(name, [(arg, label) for arg, a in t.args.items() for label, _ in a.pool])
]

CLI_CASES = [
    p
    for name, c in CLI.items()
    for p in _params(name, [(opt, label) for opt, pool in c.options.items() for label, _ in pool])
]


def test_labels_are_unique() -> None:
    """A case is named by its label (the census rebuilds it from the name)."""
    for t in TARGETS.values():
        for arg, a in t.args.items():
            labels = [label for label, _ in a.pool]
            assert len(labels) == len(set(labels)), (t.name, arg)
    for c in CLI.values():
        for opt, pool in c.options.items():
            labels = [label for label, _ in pool]
            assert len(labels) == len(set(labels)), (c.name, opt)


@pytest.fixture
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A case's folder, named so that no test id (which names the target and argument) is in
    the paths a message quotes: the judge must not find the argument's name there."""
    return tmp_path_factory.mktemp("case")


@pytest.mark.parametrize(("name", "arg", "label"), CASES)
def test_function_case(
    name: str, arg: str, label: str, folder: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(folder)  # a relative output path lands in the case's folder
    t = TARGETS[name]
    out = F.run_target(t, arg, dict(t.args[arg].pool)[label], folder)
    assert out.kind in ("ok", "refused"), str(out)


@pytest.mark.parametrize(("name", "opt", "label"), CLI_CASES)
def test_cli_case(name: str, opt: str, label: str, folder: Path) -> None:
    c = CLI[name]
    argv = F.cli_argv(c, opt, dict(c.options[opt])[label], folder)
    out = F.judge_cli(argv, folder, limit_s=c.limit_s)
    assert out.kind in ("ok", "refused"), str(out)


def test_judge_tells_bad_from_refused() -> None:
    """The judge itself: a foreign error, a message that names nothing, two lines, an insane
    result are bad; an omniloc error naming the argument is refused."""
    from omniloc.errors import InputError

    def raise_(exc: BaseException) -> None:
        raise exc

    assert F.run_call(lambda: raise_(InputError("sigma must be > 0")), ["sigma"]).kind == "refused"
    assert F.run_call(lambda: raise_(InputError("bad value")), ["sigma"]).kind == "bad"
    assert F.run_call(lambda: raise_(InputError("sigma\nbad")), ["sigma"]).kind == "bad"
    assert F.run_call(lambda: raise_(OverflowError("sigma")), ["sigma"]).kind == "bad"
    assert F.run_call(lambda: float("nan"), []).kind == "bad"
    assert F.run_call(lambda: 1.0, []).kind == "ok"
