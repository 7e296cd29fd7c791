"""Seeded byte mutations of a file's contents, shared by the fuzz tests of the binary readers."""

from __future__ import annotations

import random
from typing import Sequence, Tuple

KINDS = ("truncate", "flip", "insert", "delete")


def mutate(data: bytes, rng: random.Random, kinds: Sequence[str] = KINDS) -> Tuple[str, bytes]:
    """One mutant of ``data`` and what was done: cut, 1-3 flipped bits, 1-8 random bytes inserted or deleted.

    ``kinds`` is drawn from uniformly (name a kind twice to weigh it double).
    """
    b = bytearray(data)
    kind = rng.choice(list(kinds))
    if kind == "truncate":
        cut = rng.randrange(1, len(b))
        return f"truncate@{cut}", bytes(b[:cut])
    off = rng.randrange(len(b))
    if kind == "flip":
        bits = [(rng.randrange(len(b)), rng.randrange(8)) for _ in range(rng.randint(1, 3))]
        for o, bit in bits:
            b[o] ^= 1 << bit
        return f"flip{bits}", bytes(b)
    k = rng.randint(1, 8)
    if kind == "insert":
        return f"insert{k}@{off}", bytes(b[:off] + bytes(rng.randrange(256) for _ in range(k)) + b[off:])
    return f"delete{k}@{off}", bytes(b[:off] + b[off + k :])
