"""A figure's plumbing for :mod:`jaxga.plot` and :mod:`jaxga.plot_stats`: pyplot on a
backend that draws without a display, and a figure laid out and saved atomically."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from jaxga.core.errors import ParameterError
from jaxga.core.files import atomic_write
from jaxga.core.matplotlib_env import matplotlib_ready


def pyplot() -> Any:
    """``matplotlib.pyplot``, imported on first use, on the Agg backend unless a notebook's
    inline backend (or another already in use) draws: figures render without a display."""
    matplotlib_ready()
    import matplotlib

    if matplotlib.get_backend().lower() not in ("agg", "module://matplotlib_inline.backend_inline"):
        try:
            matplotlib.use("Agg", force=False)
        except Exception:  # pragma: no cover - a GUI backend already in use
            pass
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, out: str | Path) -> None:
    """Save ``fig`` to ``out`` (110 dpi, cropped to everything drawn: ``bbox_inches="tight"``
    keeps the axis labels and the outside legend; the format from the extension, PNG
    without one) atomically (:func:`jaxga.core.files.atomic_write`: a failed save leaves a
    previous file whole), and close it."""
    fmt = Path(out).suffix.lower().lstrip(".") or "png"
    known = fig.canvas.get_supported_filetypes()
    if fmt not in known:
        pyplot().close(fig)
        raise ParameterError(f"cannot save a figure as {out}: the format follows the "
                             f"extension, one of .{', .'.join(sorted(known))}")
    try:
        atomic_write(out, lambda f: fig.savefig(f, format=fmt, dpi=110, bbox_inches="tight"),
                     binary=True)
    finally:
        pyplot().close(fig)


def finish_figure(fig: Any, out: str | Path | None) -> Any:
    """Lay the figure out; with ``out``, save it there (:func:`save_figure`)."""
    fig.tight_layout()
    if out is not None:
        save_figure(fig, out)
    return fig
