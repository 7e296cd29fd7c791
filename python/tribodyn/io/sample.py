"""The pre-pass's bounded sample of a recording (docs/method.md 6a): up to ``PREPASS_SAMPLES`` samples,
evenly spread over a random-access recording, and the range check of its forces."""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import _core

#: Default ``min_fn``: this fraction of the median |fz| of the recording (docs/method.md 6a).
MIN_FN_FRACTION = 0.05


#: Samples the pre-pass looks at (evenly spread over a random-access recording, else the first ones): 256
#: pieces of 256 samples. 2^16 since issue 38 point 2 (docs/method.md 6a "Why 2^16"; was 2^20).
PREPASS_SAMPLES = 1 << 16


def _sample_recording(rec: Any, roles: Sequence[str], tare_n: int) -> Optional[Dict[str, np.ndarray]]:
    """Up to PREPASS_SAMPLES samples of ``roles`` (evenly spread pieces, or the first ones) and the first tare_n."""
    if not all(r in getattr(rec, "roles", {}) for r in roles):
        return None
    return sample_channels(rec, roles, tare_n)[0]


def sample_channels(rec: Any, keys: Sequence[str], tare_n: int = 0, limit: Optional[int] = None
                    ) -> Tuple[Dict[str, np.ndarray], List[Tuple[int, int]]]:  # fmt: skip
    """The pre-pass sample of a recording: up to ``limit`` (default :data:`PREPASS_SAMPLES`) samples of
    ``keys`` (roles or channel names), as 256 evenly spread pieces of a random-access recording longer
    than that, else its first samples; with ``tare_n``, the first tare_n samples as well.

    Returns the arrays and the (start, stop) of each contiguous run of samples within them (a piece,
    or a segment of the recording), so that strokes are never found across two.
    """
    n = int(rec.n_samples)
    keys = list(keys)
    limit = PREPASS_SAMPLES if limit is None else int(limit)
    if n <= limit or not getattr(rec, "random_access", False):
        stop = min(n, max(limit, tare_n))
        parts = list(rec.chunks(max(1, stop), keys, stop=stop))
        data = {r: np.concatenate([p[r] for p in parts]) if parts else np.zeros(0) for r in keys}
        segments = [(a, min(b, stop)) for a, b in (getattr(rec, "segments", None) or [(0, n)]) if a < stop]
        return data, segments or [(0, stop)]
    pieces, size = 256, max(1, limit // 256)
    starts = np.linspace(0, n - size, pieces).astype(np.int64)
    if tare_n:
        starts = np.concatenate([[0], starts])
    first = max(size, tare_n)
    ranges = [(a, min(a + (first if a == 0 else size), n)) for a in starts.tolist()]  # Python ints: no NumPy scalars
    bounds: List[Tuple[int, int]] = []
    at = 0
    for a, b in ranges:
        bounds.append((at, at + b - a))
        at += b - a
    if hasattr(rec, "read_ranges"):
        got = rec.read_ranges(ranges, keys)
        return {r: got[r] for r in keys}, bounds
    out: Dict[str, List[np.ndarray]] = {r: [] for r in keys}
    for a, b in ranges:
        for p in rec.chunks(b - a, keys, start=a, stop=b):
            for r in keys:
                out[r].append(p[r])
    return {r: np.concatenate(v) for r, v in out.items()}, bounds


def in_range(*arrays: np.ndarray) -> bool:
    """Every value of ``arrays`` finite and within +-``_core.FORCE_LIMIT`` (docs/method.md 4): two reductions
    each, no temporary (NaN fails the comparisons, as ``np.abs(v) <= FORCE_LIMIT`` does)."""
    lim = _core.FORCE_LIMIT
    return all(not v.size or bool(v.min() >= -lim and v.max() <= lim) for v in arrays)
