"""Windows of a recording that arrives chunk by chunk (docs/method.md 6).

Windows of ``length`` samples start every ``hop`` samples from the start of
the recording (``hop == length`` tiles it). :class:`Windower` receives chunks
of any sizes and hands every complete window to a callback exactly once,
with the window's samples contiguous: windows inside a chunk are read from
the chunk itself (no copy), and only the few windows that straddle a chunk
boundary are assembled from a small carried tail (< one window). Memory does
not grow with the recording, and a window's samples, hence its result, do
not depend on where the chunks were cut. Samples after the last complete
window are dropped.
"""

from __future__ import annotations

from typing import Callable, Dict

import numpy as np

__all__ = ["Windower", "Chunk"]

Chunk = Dict[str, np.ndarray]
#: callback(channels, starts relative to the arrays, absolute starts) -> None
Callback = Callable[[Chunk, np.ndarray, np.ndarray], None]


class Windower:
    """Cuts a chunked stream into windows ``[k * hop, k * hop + length)``."""

    def __init__(self, length: int, hop: int, callback: Callback, *, origin: int = 0) -> None:
        if length < 1 or hop < 1:
            raise ValueError("window length and hop must be at least one sample")
        if origin < 0:
            raise ValueError("origin must be >= 0")
        self.length = length
        self.hop = hop
        self.callback = callback
        # The stream may begin at sample `origin` of the recording (a range
        # of a long recording); windows stay on the recording's grid.
        self.seen = origin  # absolute index of the next chunk's first sample
        self.next_k = -(-origin // hop)  # first window starting at or after origin
        self.tail: Chunk = {}
        self.tail_off = self.next_k * hop  # absolute index of tail[...][0]

    def _start(self, k: int) -> int:
        return k * self.hop

    def _fits(self, end: int) -> int:
        """Index one past the last window that ends at or before ``end``."""
        if end < self.length:
            return 0
        return (end - self.length) // self.hop + 1

    def push(self, chunk: Chunk) -> None:
        """Adds the next chunk (all channels of equal length)."""
        m = len(next(iter(chunk.values()))) if chunk else 0
        c0 = self.seen
        self.seen += m
        if m == 0:
            return
        tail_len = len(next(iter(self.tail.values()))) if self.tail else 0
        if tail_len:
            # Windows starting in the tail: assemble tail + head of the chunk.
            head = min(m, self.length)
            k_end = self._fits(c0 + head)
            if k_end > self.next_k:
                small = {c: np.concatenate([self.tail[c], chunk[c][:head]]) for c in chunk}
                ks = np.arange(self.next_k, k_end)
                starts = ks * self.hop
                self.callback(small, starts - self.tail_off, starts)
                self.next_k = k_end
        # Windows entirely inside the chunk.
        k_end = self._fits(c0 + m)
        if k_end > self.next_k:
            ks = np.arange(self.next_k, k_end)
            starts = ks * self.hop
            if starts[0] < c0:  # the tail step above emits every earlier window
                raise RuntimeError("internal error: window before the chunk was not emitted")
            self.callback(chunk, starts - c0, starts)
            self.next_k = k_end
        # Carry what the next window needs.
        s = self._start(self.next_k)
        if s < c0:
            self.tail = {c: np.concatenate([self.tail[c][s - self.tail_off :], chunk[c]]) for c in chunk}
            self.tail_off = s
        elif s < c0 + m:
            self.tail = {c: chunk[c][s - c0 :].copy() for c in chunk}
            self.tail_off = s
        else:
            self.tail = {}
            self.tail_off = s
