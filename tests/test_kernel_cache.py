"""numba's cache is dropped when any kernel source changes (it only checks each function's own
file, so a kernel calling an edited helper in another file kept the old code)."""

from __future__ import annotations

from pathlib import Path

from omniloc._kernels import STAMP, clear_stale_cache


def _cached(folder: Path) -> list[str]:
    return sorted(
        p.name for p in (folder / "__pycache__").iterdir() if p.suffix in (".nbi", ".nbc")
    )


def test_a_change_to_any_kernel_source_drops_the_compiled_code(tmp_path: Path) -> None:
    (tmp_path / "geometry.py").write_text("def helper(): return 1\n")
    (tmp_path / "search.py").write_text("def kernel(): return helper()\n")
    cache = tmp_path / "__pycache__"
    cache.mkdir()
    (cache / "search.kernel-1.py311.nbi").write_bytes(b"index")
    (cache / "search.kernel-1.py311.1.nbc").write_bytes(b"code")
    (cache / "search.cpython-311.pyc").write_bytes(b"python's own")
    # No stamp yet: what is cached may be from any source.
    assert clear_stale_cache(tmp_path)
    assert _cached(tmp_path) == []
    assert (cache / "search.cpython-311.pyc").exists()
    assert (cache / STAMP).is_file()
    # Compiled again from these sources: kept while they stand.
    (cache / "search.kernel-1.py311.nbi").write_bytes(b"index")
    assert not clear_stale_cache(tmp_path)
    assert _cached(tmp_path) == ["search.kernel-1.py311.nbi"]
    # The helper's file changes, the kernel's does not: the kernel's code goes too.
    (tmp_path / "geometry.py").write_text("def helper(): return 2\n")
    assert clear_stale_cache(tmp_path)
    assert _cached(tmp_path) == []
    assert not clear_stale_cache(tmp_path)


def test_a_folder_that_cannot_be_written_is_left_alone(tmp_path: Path) -> None:
    (tmp_path / "geometry.py").write_text("x = 1\n")
    (tmp_path / "__pycache__").write_text("a file where the cache folder would be")
    assert not clear_stale_cache(tmp_path)


def test_the_installed_kernels_carry_the_stamp_of_their_sources() -> None:
    import omniloc._kernels as kernels

    folder = Path(kernels.__file__).parent
    assert not clear_stale_cache(folder)  # done once, at import
