"""A stick-slip simulator whose truth is known (issue 35 point 1, docs/method.md 6g), for
tests/analyses/test_stick_slip.py and tests/measure_stick_slip.py.

Unidirectional sliding under a dead weight; the friction force is mu Fn plus, with stick-slip, a saw-tooth
whose stick rises linearly for a stick time (jittered by +-20 % per cycle) and whose slip falls by the
amplitude along a half cosine, (1 - cos(pi u)) / 2, over the slip duration. Forces carry white noise and,
when ``quantum`` is given, are rounded to multiples of it (an export's resolution). The negative cases:
smooth sliding (white and low-frequency noise, a drift), a 1 Hz log (a wandering COF, its values rounded
to 0.1 N) and a quantised steady signal (noise under the resolution, a drift across many steps).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Optional

import numpy as np

FN = 20.0  # N, dead weight
MU = 0.3
QUANTUM = 0.0625  # N: the quantised cases' resolution (an eighth of the default amplitude)
LEAD_IN = 1.0  # s unloaded before the load is applied (truth times count from the load)


@dataclass(frozen=True)
class Case:
    """A simulated recording: channels, rate and, with stick-slip, the truth (slip starts and ends in s)."""

    channels: Dict[str, np.ndarray]
    fs: float
    amplitude: float  # the whole drop (N), 0 without stick-slip
    starts: np.ndarray
    ends: np.ndarray

    @property
    def present(self) -> bool:
        return self.amplitude > 0


def _ar1(rng: np.random.Generator, n: int, phi: float, sd: float) -> np.ndarray:
    """An AR(1) series of stationary SD ``sd``."""
    from scipy.signal import lfilter

    e = rng.standard_normal(n) * sd * np.sqrt(1 - phi * phi)
    x0 = rng.standard_normal() * sd
    return np.asarray(lfilter([1.0], [1.0, -phi], e, zi=[phi * x0])[0])


def _quantise(x: np.ndarray, q: Optional[float]) -> np.ndarray:
    return x if not q else np.round(x / q) * q


def _unloaded(rng: np.random.Generator, fs: float, noise: float, ch: Dict[str, np.ndarray]) -> Dict[str, np.ndarray]:
    """The channels after LEAD_IN s unloaded (forces zero plus noise): the tare and the contact are known."""
    m = int(LEAD_IN * fs)
    return {c: np.concatenate([noise * rng.standard_normal(m), v]) for c, v in ch.items()}


def stick_slip(
    seed: int,
    *,
    fs: float,
    slip: float,
    stick: Optional[float] = None,
    amplitude: float = 0.5,
    noise: float = 0.05,
    quantum: Optional[float] = None,
    cycles: int = 60,
) -> Case:
    """Stick-slip: ``cycles`` cycles of a stick (default max(0.3 s, 10 slip), +-20 % per cycle) and a slip of
    ``slip`` s falling by ``amplitude`` N; fy noise ``noise`` N (fz: a quarter of it); forces rounded to
    ``quantum``."""
    rng = np.random.default_rng(seed)
    stick = max(0.3, 10 * slip) if stick is None else stick
    sticks = stick * rng.uniform(0.8, 1.2, cycles + 1)
    t0 = rng.uniform(0.2, 0.5)  # sliding at constant speed from 0; the first stick starts at t0
    starts = t0 + np.cumsum(sticks[:-1]) + slip * np.arange(cycles)
    ends = starts + slip
    duration = float(ends[-1] + sticks[-1])
    n = int(duration * fs)
    t = (np.arange(n) + rng.uniform()) / fs
    # the saw-tooth: a linear rise of `amplitude` over each stick, a half-cosine fall over each slip
    k = np.searchsorted(ends, t, side="right")  # cycles completed
    prev_end = np.where(k > 0, ends[np.maximum(k - 1, 0)], t0)
    nxt = starts[np.minimum(k, cycles - 1)]
    rise = np.clip((t - prev_end) / np.where(k < cycles, nxt - prev_end, sticks[-1]), 0.0, 1.0)
    u = np.clip((t - nxt) / slip, 0.0, 1.0) if slip > 0 else (t >= nxt).astype(float)
    fall = np.where(k < cycles, 0.5 * (1 - np.cos(np.pi * u)), 0.0)
    saw = amplitude * (rise - fall)
    saw[t < t0] = 0.0
    fz = FN + 0.25 * noise * rng.standard_normal(n)
    fy = -(MU * FN + saw) + noise * rng.standard_normal(n)  # friction on -y
    ch = _unloaded(rng, fs, noise, {"fy": fy, "fz": fz})
    ch = {c: _quantise(v, quantum) for c, v in ch.items()}
    return Case(ch, float(fs), float(amplitude), starts + LEAD_IN, ends + LEAD_IN)


def smooth(seed: int, *, fs: float, duration: float = 60.0, noise: float = 0.05) -> Case:
    """Smooth sliding: white noise, low-frequency noise (AR(1), 0.1 s, 0.6 x noise) and a slow drift."""
    rng = np.random.default_rng(seed)
    n = int(duration * fs)
    t = np.arange(n) / fs
    phi = float(np.exp(-1.0 / (0.1 * fs)))
    f = MU * FN * (1 + 0.02 * np.sin(2 * np.pi * t / 40 + rng.uniform(0, 6.3))) + _ar1(rng, n, phi, 0.6 * noise)
    fy = -f + noise * rng.standard_normal(n)
    fz = FN + 0.25 * noise * rng.standard_normal(n)
    return Case(_unloaded(rng, fs, noise, {"fy": fy, "fz": fz}), float(fs), 0.0, np.zeros(0), np.zeros(0))


def low_rate(seed: int, *, duration: float = 1800.0, quantum: Optional[float] = 0.1) -> Case:
    """A steady 1 Hz log: a COF wandering (AR(1), 10 s, 2 % of the force) after a running-in, 0.5 % white
    noise (Student t, 3 degrees of freedom), forces rounded to ``quantum`` (0.1 N: one decimal)."""
    rng = np.random.default_rng(seed)
    n = int(duration)
    t = np.arange(n, dtype=float)
    f = MU * FN * (1 + 0.3 * np.exp(-t / 120.0)) + _ar1(rng, n, float(np.exp(-0.1)), 0.02 * MU * FN)
    # the log's own sample-to-sample variation: heavy-tailed (Student t, 3 degrees of freedom)
    fy = -(f + 0.005 * MU * FN * rng.standard_t(3, n))
    fz = FN + 0.002 * FN * rng.standard_normal(n)
    ch = _unloaded(rng, 1.0, 0.04, {"fy": fy, "fz": fz})
    return Case({c: _quantise(v, quantum) for c, v in ch.items()}, 1.0, 0.0, np.zeros(0), np.zeros(0))


def quantised_steady(seed: int, *, fs: float = 1000.0, duration: float = 60.0, quantum: float = 0.27,
                     noise: float = 0.1) -> Case:  # fmt: skip
    """A steady signal quantised in steps of ``quantum`` N: noise ``noise`` steps, a drift across 4 steps."""
    rng = np.random.default_rng(seed)
    n = int(duration * fs)
    t = np.arange(n) / fs
    f = MU * FN + 2 * quantum * np.sin(2 * np.pi * t / duration + rng.uniform(0, 6.3))
    fy = -(f + noise * quantum * rng.standard_normal(n))
    fz = FN + noise * quantum * rng.standard_normal(n)
    ch = _unloaded(rng, fs, noise * quantum, {"fy": fy, "fz": fz})
    return Case({c: _quantise(v, quantum) for c, v in ch.items()}, float(fs), 0.0, np.zeros(0), np.zeros(0))
