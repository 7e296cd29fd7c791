"""The progress bar of the CLI and of ``analyze(progress=True)``: tqdm, kept on screen when done.

The width is the terminal's, or 80 columns when it cannot be known (a
terminal emulator that reports none, ``TERM=dumb``): tqdm alone then draws
no bar at all. The bar goes to stderr and shows the rate and the ETA.
"""

from __future__ import annotations

import shutil
from typing import Any, Optional

__all__ = ["progress_bar", "DEFAULT_COLUMNS"]

#: Width of the bar when the terminal's is unknown.
DEFAULT_COLUMNS = 80


def progress_bar(total: Optional[int], *, unit: str, desc: str, unit_scale: bool = False) -> Any:
    """A tqdm bar with an ETA that stays visible at the end (``leave=True``); None without tqdm."""
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover - tqdm is a dependency
        return None
    cols = shutil.get_terminal_size((DEFAULT_COLUMNS, 24)).columns or DEFAULT_COLUMNS
    return tqdm(
        total=total,
        unit=unit,
        unit_scale=unit_scale,
        desc=desc,
        leave=True,
        ncols=max(cols, 40),
        dynamic_ncols=False,
        mininterval=0.2,
    )
