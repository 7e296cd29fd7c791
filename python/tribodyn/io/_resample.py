"""The bound on ``resample=`` shared by the text and table readers (a leaf module: issue 34's
``--resample 1e9`` asked for 30 GiB)."""

from __future__ import annotations

import math

from .base import RecordingError

__all__ = ["MAX_RESAMPLED_BYTES", "check_resample_size"]

#: Largest memory the resampled channels of one recording may take together (``resample=``): a rate
#: far above the file's own (``--resample 1e9``) is refused in one line before anything is allocated.
MAX_RESAMPLED_BYTES = 2 << 30


def check_resample_size(path: str, hz: float, duration: float, n_channels: int, rows: int) -> int:
    """Samples per channel that ``resample=hz`` makes of ``duration`` seconds, or a RecordingError when
    the ``n_channels`` resampled channels would need more than :data:`MAX_RESAMPLED_BYTES`."""
    samples = math.floor(duration * hz + 1e-9) + 1 if math.isfinite(duration) and duration >= 0 else 1
    need = samples * max(n_channels, 1) * 8
    if need > MAX_RESAMPLED_BYTES:
        native = (rows - 1) / duration if duration > 0 and rows > 1 else float("nan")
        raise RecordingError(
            f"{path}: resample={hz:g} Hz would make {samples:.3g} samples per channel from {rows} rows "
            f"({need / 2**30:.3g} GiB for {n_channels} channel(s), at most {MAX_RESAMPLED_BYTES / 2**30:g} GiB): "
            f"choose a rate near the file's own (about {native:.4g} Hz)"
        )
    return samples
