"""Writing a figure: the one place that turns a bad path or format into a clear error."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..errors import InputError
from ..io import as_path, make_folder


def save_figure(fig: Any, path: object, error: type[InputError] = InputError) -> Path:
    """Save ``fig`` to ``path`` (its folder is created), or raise ``error`` naming the path.

    The format comes from the extension, which must be one matplotlib writes (``.png``,
    ``.pdf``, ``.svg`` ...); a missing one is refused rather than guessed.
    """
    p = as_path(path, "figure path", error)
    formats = fig.canvas.get_supported_filetypes()
    ext = p.suffix[1:].lower()
    if ext not in formats:
        shown = ", ".join(f".{k}" for k in sorted(formats) if k in ("png", "pdf", "svg", "jpg"))
        raise error(
            f"figure {p}: "
            + (f"unknown format '.{ext}'" if ext else "no file extension")
            + f" (use one of {shown}, ...)"
        )
    make_folder(p.parent, f"cannot write figure {p.name}", error)
    if p.is_dir():
        raise error(f"figure {p}: is a directory, not a file")
    try:
        fig.savefig(p, dpi=110)
    except OSError as exc:
        raise error(f"cannot write figure {p}: {exc.strerror or exc}") from None
    return p
