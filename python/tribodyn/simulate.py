"""Simulated brush/commutator rig with a KNOWN coefficient of friction.

This module reproduces the rig of the seed paper (docs/method.md section 8) closely
enough to serve as the bundled example and as the source of truth for tests.
It is written from the physics below, never fitted to the analysis code, and
it only needs NumPy and SciPy (it imports nothing else from ``tribodyn``).

Rig
---
250 rpm (rotation frequency ``f0 = 4.1667 Hz``), 24 lamellas (lamella
frequency ``f_l = 100 Hz``), sampled at ``fs = 1 kHz`` by a 16-bit converter.
Time of sample ``n`` is ``n / fs``.

Model (per sample)
------------------
* Dynamic normal force ``fz_d``: commutator run-out at ``f0`` and its 2nd and
  3rd harmonics (random amplitudes and phases drawn from the seed), the
  lamella excitation at ``f_l`` (amplitude modulated at ``f0``, lamella to
  lamella variation) and ``2 f_l``, plus broadband brush dynamics (white noise
  through a 2nd-order Butterworth band-pass 5-250 Hz). The sum is passed
  through a soft limiter ``A tanh(x / A)`` with ``A = 2.2 N`` so that
  ``fz_d`` spans about -2..+2 N and the contact force stays positive.
* Contact (normal) force ``N = N0 + fz_d`` with the static preload
  ``N0 = 2.5 N``; ``N >= 0.3 N`` always, except in contact-loss episodes
  (below), where ``N = max(0, N0 (1 - 0.8 c) + (1 + c) fz_d)`` with the
  contact-loss level ``c`` in [0, 1]: the burned-out brush bounces and the
  contact force is intermittently zero.
* Friction (Coulomb): ``F_t = mu(t, N) N`` with
  ``mu(t, N) = mu0(t) (1 + beta (N - N0) / N0)``, ``beta`` being the
  ``force_dependence`` option (default 0). With ``beta != 0`` the
  least-squares slope of fy on fz is about ``mu0 (1 + beta)`` and the
  per-sample COF grows with the normal force; because the high-pass also
  removes the mean of the quadratic term, the paper's deadband measure
  ``(mu_b - mu_a) / mu_r`` (0.35 N) is only about ``0.11 beta``.
* Measured (DC-coupled) forces, before the amplifier:
  ``fy = s F_t + e_y`` (``s`` = orientation, default -1 as in the paper's
  Fig. 5, ``e_y`` white, 0.01 N: micro-slip and sensor noise);
  ``fz = N + e_z`` (0.005 N); ``fx = 0.2 fz_d + b_x + e_x`` where ``b_x`` is
  independent band-limited noise (2-150 Hz, 0.4 N) so that ``|C_xz|`` and
  ``|C_xy|`` stay well below ``|C_yz|``. During contact loss independent brush
  ringing (band-pass 150-350 Hz, ``0.5 c`` N) is added to all three
  channels: the forcemeter then measures the brush's inertial forces, which
  breaks the friction/normal correlation (``|C_yz| << 0.85``).
* Optional current channel ``i`` (A): the set current times
  ``(1 + 0.01 sin(2 pi f_l t + phi))`` (commutation ripple) plus 0.01 A
  white noise. It is never high-pass filtered.
* Channel skew ``k`` (``skew`` option): ``fz`` is DELAYED by ``k`` samples
  relative to ``fy``, ``fx`` and ``i`` (``fz[n] = z[n - k]``; a negative ``k``
  delays ``fy``, ``fx`` and ``i`` by ``-k`` instead). With the lag convention
  of docs/method.md section 1 (if y is x delayed by d, ``C_xy`` peaks at +d), the
  lag of max ``|C(fy, fz)(j)|`` is ``j = +k``.
* Charge amplifier (unless ``raw=True``): 1st-order Butterworth high-pass at
  0.1 Hz, ``scipy.signal.butter(1, 0.1, "highpass", fs=fs, output="sos")``
  applied with ``sosfilt``; its state is initialised with
  ``sosfilt_zi(sos) * static`` where ``static`` is the noise-free static level
  of the channel at t = 0 (``N0`` for fz, ``s mu0(0) N0`` for fy, 0 for fx),
  i.e. the amplifier has been on long before the recording: no start-up
  transient. (Initialising with the first sample instead would leave a
  decaying offset of ``-fz_d[0]``.)
* 16-bit quantisation: forces full scale +-10 N (LSB = 20/65536 N), current
  full scale +-50 A. ``raw=True`` returns the DC-coupled forces (preload
  included, no high-pass), still quantised.

Measurement conditions (:func:`conditions`)
-------------------------------------------
A stationary recording at constant ``mu`` for the statistics of the COF
identification (issue 12). The true contact force ``N`` is the rig's DC
fz above (``mu0 = 1``, ``beta = 0``, no skew, mean about ``N0``); on it:

* Force-dependent friction: ``mu(N) = mu (1 + beta (N - N0))`` with ``beta``
  per newton (NOT relative to ``N0`` as the ``force_dependence`` of the
  other scenarios), so ``d mu / d N = mu beta`` and
  ``fy = s mu (1 - beta N0) N + s mu beta N^2`` exactly (clipped at
  ``mu(t, N) >= 0``).
* Friction ripple at the lamella frequency ``f_l = N_LAMELLAS RPM / 60``:
  ``mu(t) -> mu (1 + r sin(2 pi f_l t + phi))``, ``phi`` drawn from the seed.
* ``fy = s mu(t, N) N + e_y + d_y``: ``e_y`` white or band noise (2nd-order
  Butterworth band-pass 20-200 Hz) of std ``y_noise``; ``d_y`` a
  low-frequency disturbance, white noise through a 2nd-order Butterworth
  low-pass at 2 Hz, of std ``drift``.
* Inter-channel delay ``d`` (samples, fractional, either sign): the measured
  fz is the true one delayed, ``fz[n] = N(n - d)``, applied exactly as a
  band-limited shift ``exp(-2j pi f d)`` in the frequency domain (after
  removing the straight line through the record's end points, which is
  shifted analytically) on a record padded by 2 s at each end.
* ``fz = N(n - d) + e_z``: measurement noise that is not contact force,
  white or band (20-200 Hz), of std ``std(N - mean N) 10^(-SNR_z/20)``; OLS
  of fy on fz is then attenuated by ``1 / (1 + 10^(-SNR_z/10))``.
* fx: the rig's fx (``0.2 fz_d`` plus 0.4 N band noise), not delayed.
* Every noise is scaled to its stated std exactly over the returned record
  (before the amplifier). Then the charge amplifier (the 0.1 Hz high-pass,
  started from the mean of the first padded second, so the 2 s pad absorbs
  any start-up transient) and the 16-bit converter as above; ``raw=True``
  skips the high-pass.
* Randomness: the rig's own streams plus one generator seeded by
  ``(seed, 12)`` that always draws, in order, ``phi`` and the unit noises of
  fz, fy and the disturbance, so switching one condition on or off leaves
  the others' realisations unchanged.

Determinism and streaming
-------------------------
All randomness is drawn per fixed block of 1 s (``round(fs)`` samples) from
a generator seeded by ``(seed, block index)``; rotor phases come from
``(seed, 0)``; the temperature log from ``(seed, 2)``. Filters carry their
state between chunks, so the signal does not depend on how it is cut into
chunks (see :func:`continuous`). The generator runs a 1 s pre-roll before
t = 0 so the filters are settled and the skew delay line is filled.

Scenarios
---------
:func:`temperature_test`
    4060 s, commutator temperature 155 -> 175 -> 135 -> 130 -> 135 -> 100 degC
    (piecewise linear, see ``TEMPERATURE_PATH``), irregular temperature log
    (every 100-200 s, plus a reading at each breakpoint of the path).
    COF = 0.1 inside an optimum interval and rising smoothly outside, with a
    rate-independent hysteresis of the upper edge (play operator, see
    :func:`cof_vs_temperature`): optimum 135-160 degC while heating and
    135-155 degC while cooling.
:func:`current_density_test`
    1 mm^2 tip, 700 s, J stepped 2 -> 6.5 A/mm^2 by 0.5 A/mm^2 every 70 s,
    COF minimum 0.1 for 4.25 <= J <= 4.75 A/mm^2 (see
    :func:`cof_vs_current_density`), 0.25 at 6 A/mm^2, contact loss from
    632 s to the end.
:func:`continuous`
    Stationary run of any length, yielded chunk by chunk.
:func:`conditions`
    Stationary run (whole record) under controlled measurement conditions:
    noise on fz at a given SNR, white or band noise on fy, a low-frequency
    disturbance on fy, friction ripple at ``f_l``, a fractional fy/fz delay
    and a force-dependent COF (see "Measurement conditions" above).

Ground truth (:class:`Truth`) is tabulated on a 0.1 s grid (``TRUTH_DT``)
covering ``[0, duration]``.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from scipy import signal
from scipy.interpolate import PchipInterpolator

__all__ = [
    "N_LAMELLAS",
    "acquisitions",
    "ReciprocatingSimulation",
    "StribeckModel",
    "StribeckSimulation",
    "reciprocating",
    "stribeck_sweep",
    "RunningInSimulation",
    "running_in",
    "STEADY_DELTA",
    "PRELOAD_N",
    "RPM",
    "TEMPERATURE_PATH",
    "T_RUNNING_IN_S",
    "TRUTH_DT",
    "Simulation",
    "Truth",
    "cof_vs_current_density",
    "cof_vs_temperature",
    "conditions",
    "curved_bathtub",
    "CURVED_J",
    "continuous",
    "current_density_test",
    "scenario",
    "temperature_test",
]

# --------------------------------------------------------------------------
# Rig constants (docs/method.md section 8)
# --------------------------------------------------------------------------
RPM: float = 250.0
N_LAMELLAS: int = 24
PRELOAD_N: float = 2.5  #: static preload N0 (N)
TRUTH_DT: float = 0.1  #: spacing of the ground-truth grid (s)

FULL_SCALE_N: float = 10.0  #: +- full scale of the force channels (N)
FULL_SCALE_A: float = 50.0  #: +- full scale of the current channel (A)
ADC_BITS: int = 16
HP_CUTOFF_HZ: float = 0.1
HP_ORDER: int = 1

_LIMIT_N = 2.2  # soft limit of fz_d (N)
_BB_STD = 0.25  # broadband brush dynamics in fz_d (N)
_X_STD = 0.40  # independent axial noise (N)
_X_COUPLING = 0.2  # fx = 0.2 fz_d + ...
_RING_STD = 0.50  # brush ringing in contact loss (N, times c)
_NOISE_Y = 0.010
_NOISE_Z = 0.005
_NOISE_X = 0.005
_NOISE_I = 0.010
_RIPPLE_I = 0.01
_LOSS_PRELOAD_DROP = 0.8
_LOSS_DYN_GAIN = 1.0

# White-noise streams per block, by namespace: forces (always drawn), brush
# ringing (only with a contact-loss schedule), current (only with a current).
_NS_FORCE, _NS_RING, _NS_CURRENT = 1, 3, 4
_S_BB, _S_X, _S_EX, _S_EY, _S_EZ = range(5)
_N_STREAMS = {_NS_FORCE: 5, _NS_RING: 3, _NS_CURRENT: 1}
_BLOCK_OFFSET = 2**32  # keeps block indices of the pre-roll non-negative

#: (t_s, T_degC) breakpoints of the temperature test (piecewise linear).
TEMPERATURE_PATH: tuple[tuple[float, float], ...] = (
    (0.0, 155.0),
    (1000.0, 155.0),
    (2000.0, 175.0),
    (3550.0, 135.0),
    (3650.0, 130.0),
    (3750.0, 135.0),
    (3950.0, 135.0),
    (4010.0, 100.0),
    (4060.0, 100.0),
)

# COF(T) model: flat bottom MU_MIN on [lo, hi], Huber-shaped walls (quadratic
# over the first _T_W degC, then linear); the upper wall sees the temperature
# through a play operator (hysteresis).
_T_MU_MIN = 0.10
_T_LO = 135.0
_T_HI = 157.5
_T_W = 3.0
_T_K_LO = 0.0045  # per degC below lo
_T_K_HI = 0.0042  # per degC above hi
_T_PLAY = 2.5  # half width of the play (hysteresis), degC
#: Time constant (s) of the temperature test's optional running-in on its start plateau (issue 35).
T_RUNNING_IN_S = 150.0

# COF(J) model: monotone cubic (PCHIP) through these knots; flat on 4.25-4.75.
_J_KNOTS = np.array([2.0, 3.0, 3.5, 4.0, 4.25, 4.75, 5.0, 5.5, 6.0, 6.5])
_J_MU = np.array([0.17, 0.165, 0.14, 0.112, 0.10, 0.10, 0.104, 0.13, 0.25, 0.30])
_J_OPT = (4.25, 4.75)
_J_TAU_S = 2.0  # COF response time to a current step
_CD_DURATION = 700.0
_CD_STEP_S = 70.0
_CD_J0, _CD_J1, _CD_DJ = 2.0, 6.5, 0.5
_CD_LOSS_START = 632.0
_CD_LOSS_RAMP = 1.0
_CD_AREA = 1.0

_ArrayFn = Callable[[np.ndarray], np.ndarray]


# --------------------------------------------------------------------------
# Public result types
# --------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class Truth:
    """Ground truth of a simulated recording.

    Attributes
    ----------
    t : ndarray
        Time axis of the truth samples (s), a ``TRUTH_DT`` = 0.1 s grid from
        0 to the duration (same time axis as the channels: sample ``n`` is at
        ``n / fs``).
    mu : ndarray
        True COF ``mu0(t)`` (at the preload, i.e. without the normal-force
        dependence) on ``t``.
    temperature : ndarray or None
        True commutator temperature T(t) (degC) on ``t``.
    current_density : ndarray or None
        True current density J(t) (A/mm^2) on ``t``.
    contact_loss : tuple of (t0, t1)
        Contact-loss intervals (s); empty when the contact is never lost.
    optimum : mapping
        Simulated optimum intervals (lo, hi): ``{"temperature": ...,
        "temperature_heating": ..., "temperature_cooling": ...}`` or
        ``{"current_density": ...}``; the COF equals its minimum exactly on
        these intervals.
    force_dependence : float
        ``beta`` of ``mu = mu0 (1 + beta (N - N0) / N0)``.
    skew : int
        Samples by which fz is delayed relative to fy/fx (lag of max
        ``|C(fy, fz)|``).
    params : mapping
        Other model parameters (preload, curve parameters, ...).
    """

    t: np.ndarray
    mu: np.ndarray
    temperature: np.ndarray | None
    current_density: np.ndarray | None
    contact_loss: tuple[tuple[float, float], ...]
    optimum: Mapping[str, tuple[float, float]]
    force_dependence: float
    skew: int
    params: Mapping[str, Any] = field(default_factory=dict)

    def _interp(self, values: np.ndarray | None, times: Any) -> np.ndarray:
        times = np.asarray(times, dtype=np.float64)
        if values is None:
            return np.full(times.shape, np.nan)
        out: np.ndarray = np.interp(times, self.t, values, left=np.nan, right=np.nan)
        return out

    def mu_at(self, times: Any) -> np.ndarray:
        """True COF ``mu0`` interpolated linearly at ``times`` (s).

        NaN outside ``[t[0], t[-1]]``. Scalars give 0-d arrays.
        """
        return self._interp(self.mu, times)

    def temperature_at(self, times: Any) -> np.ndarray:
        """True temperature (degC) at ``times``; NaN if not simulated."""
        return self._interp(self.temperature, times)

    def current_density_at(self, times: Any) -> np.ndarray:
        """True current density (A/mm^2) at ``times``; NaN if not simulated."""
        return self._interp(self.current_density, times)

    def in_contact_loss(self, times: Any, half_width: float = 0.0) -> np.ndarray:
        """Whether ``[t - half_width, t + half_width]`` meets a contact-loss interval.

        Parameters
        ----------
        times : array_like
            Times (s), e.g. window centres.
        half_width : float
            Half the window length (s); 0 tests the instants themselves.

        Returns
        -------
        ndarray of bool, shaped like ``times``.
        """
        times = np.asarray(times, dtype=np.float64)
        out = np.zeros(times.shape, dtype=bool)
        for t0, t1 in self.contact_loss:
            out |= (times + half_width >= t0) & (times - half_width <= t1)
        return out


@dataclass(frozen=True, eq=False)
class Simulation:
    """A simulated recording.

    Attributes
    ----------
    fs : float
        Sampling rate (Hz).
    channels : dict
        Role -> float64 array, all of equal length: ``"fx"``, ``"fy"``,
        ``"fz"`` (N) and, for the current-density test, ``"i"`` (A).
    temperature_log : (t_s, T_degC) or None
        Intermittent temperature readings, sorted by time.
    area_mm2 : float or None
        Contact area of the brush tip (mm^2).
    rpm : float
        Rotating speed.
    n_lamellas : int
        Number of commutator lamellas.
    orientation : int
        +1 or -1: sign relating fy to the friction force (fy = s F_t).
    truth : Truth
        Ground truth.
    """

    fs: float
    channels: dict[str, np.ndarray]
    temperature_log: tuple[np.ndarray, np.ndarray] | None
    area_mm2: float | None
    rpm: float
    n_lamellas: int
    orientation: int
    truth: Truth

    @property
    def n_samples(self) -> int:
        """Number of samples per channel."""
        return int(next(iter(self.channels.values())).size)

    @property
    def duration(self) -> float:
        """Length of the recording (s): ``n_samples / fs``."""
        return self.n_samples / self.fs

    @property
    def time(self) -> np.ndarray:
        """Sample times ``n / fs`` (s)."""
        return np.arange(self.n_samples, dtype=np.float64) / self.fs


# --------------------------------------------------------------------------
# COF curves (ground truth models)
# --------------------------------------------------------------------------
def _huber(u: np.ndarray, w: float) -> np.ndarray:
    """0 for u <= 0, u^2/(2w) for 0 < u < w, u - w/2 beyond (C1-smooth)."""
    u = np.maximum(u, 0.0)
    return np.where(u < w, u * u / (2.0 * w), u - 0.5 * w)


def _mu_of_temperature(temperature: np.ndarray, upper: np.ndarray) -> np.ndarray:
    return _T_MU_MIN + _T_K_LO * _huber(_T_LO - temperature, _T_W) + _T_K_HI * _huber(upper - _T_HI, _T_W)


def cof_vs_temperature(temperature: Any, branch: str = "heating") -> np.ndarray:
    """COF of the temperature test against the commutator temperature.

    The COF is 0.1 inside the optimum and rises outside with C1-smooth walls
    (quadratic over the first 3 degC, then 0.0045/degC below 135 degC and
    0.0042/degC above the upper edge). The upper edge has a hysteresis (the
    contact zone needs time to recover after overheating, paper Sec. 4.1):
    the upper wall sees the temperature through a play (backlash) operator of
    half width 2.5 degC, ``T_up = T - 2.5`` while heating, ``T + 2.5`` while
    cooling, constant for 5 degC after a reversal. The hysteresis is rate
    independent and the COF stays continuous in time.

    Parameters
    ----------
    temperature : array_like
        Commutator temperature (degC).
    branch : {"heating", "cooling", "quasistatic"}
        Monotone heating or cooling branch; "quasistatic" is the curve
        without play (the middle of the loop).

    Returns
    -------
    ndarray
        COF. Optimum (COF = 0.1 exactly): 135-160 degC heating, 135-155 degC
        cooling, 135-157.5 degC quasistatic.
    """
    t = np.asarray(temperature, dtype=np.float64)
    shift = {"heating": -_T_PLAY, "cooling": _T_PLAY, "quasistatic": 0.0}
    if branch not in shift:
        raise ValueError(f"branch must be 'heating', 'cooling' or 'quasistatic', got {branch!r}")
    return _mu_of_temperature(t, t + shift[branch])


_J_CURVE = PchipInterpolator(_J_KNOTS, _J_MU, extrapolate=False)


def cof_vs_current_density(j: Any) -> np.ndarray:
    """Steady-state COF of the current-density test against J (A/mm^2).

    Monotone cubic (PCHIP) through the knots J = 2, 3, 3.5, 4, 4.25, 4.75,
    5, 5.5, 6, 6.5 with COF 0.17, 0.165, 0.14, 0.112, 0.10, 0.10, 0.104, 0.13,
    0.25, 0.30: little effect below ~3 A/mm^2, a fast decrease to the minimum
    0.1 (exactly flat on 4.25-4.75 A/mm^2), then a steep rise to 0.25 at
    6 A/mm^2. Clamped to the end values outside 2-6.5 A/mm^2.
    """
    j = np.clip(np.asarray(j, dtype=np.float64), _J_KNOTS[0], _J_KNOTS[-1])
    return np.asarray(_J_CURVE(j), dtype=np.float64)


#: The curved bathtub of ``current_density_test(bathtub="curved")`` (issue 23, point 5):
#: flat at 0.17 below 3.0 A/mm^2, a smooth (C1) descent to the floor 0.1 at
#: 4.3, flat to 4.8, then a wall with a curved onset (Huber, 0.5 A/mm^2)
#: rising 0.15 per A/mm^2.
CURVED_J = {"lo": 4.3, "hi": 4.8, "floor": 0.10, "rise_lo": 0.07, "width_lo": 1.3, "slope_hi": 0.15,
            "width_hi": 0.5}  # fmt: skip


def curved_bathtub(
    x: Any,
    lo: float,
    hi: float,
    *,
    floor: float = 0.1,
    rise_lo: float = 0.07,
    width_lo: float = 1.0,
    slope_hi: float = 0.15,
    width_hi: float = 0.5,
) -> np.ndarray:
    """A bathtub whose walls are curved: flat below, smooth into the floor (issue 23).

    ``floor`` on ``[lo, hi]``; below ``lo`` the COF rises along a smoothstep
    ``3 u^2 - 2 u^3`` (``u = (lo - x) / width_lo`` clipped to [0, 1]) to
    ``floor + rise_lo`` and stays there (a lower wall that is flat below
    ``lo - width_lo``); above ``hi`` it rises as ``slope_hi *
    huber(x - hi, width_hi)`` (quadratic over ``width_hi``, then linear).
    The COF departs from the floor exactly at ``lo`` and ``hi``.
    """
    x = np.asarray(x, dtype=np.float64)
    u = np.clip((lo - x) / width_lo, 0.0, 1.0)
    return np.asarray(floor + rise_lo * u * u * (3.0 - 2.0 * u) + slope_hi * _huber(x - hi, width_hi),
                      dtype=np.float64)  # fmt: skip


# --------------------------------------------------------------------------
# The rig (physics, DC-coupled) and the acquisition chain
# --------------------------------------------------------------------------
def _band_sos(lo: float, hi: float, fs: float) -> tuple[np.ndarray, float]:
    """2nd-order Butterworth band-pass and its output std for unit white input."""
    hi = min(hi, 0.4 * fs)
    lo = min(lo, 0.5 * hi)
    sos = signal.butter(2, [lo, hi], btype="bandpass", fs=fs, output="sos")
    n = max(8192, int(20.0 * fs / lo))
    imp = np.zeros(n)
    imp[0] = 1.0
    h = signal.sosfilt(sos, imp)
    return sos, float(np.sqrt(np.sum(h * h)))


class _Rig:
    """Generates the DC-coupled forces (and current) chunk by chunk."""

    def __init__(
        self,
        *,
        fs: float,
        seed: int,
        orientation: int,
        beta: float,
        mu0_fn: _ArrayFn,
        n0: float = PRELOAD_N,
        loss_fn: _ArrayFn | None = None,
        current_fn: _ArrayFn | None = None,
        start_index: int = 0,
        rpm: float = RPM,
    ) -> None:
        self.fs = float(fs)
        self.seed = int(seed)
        self.s = float(orientation)
        self.beta = float(beta)
        self.mu0_fn = mu0_fn
        self.n0 = float(n0)
        self.loss_fn = loss_fn
        self.current_fn = current_fn
        self.block = max(1, round(self.fs))
        self.m = int(start_index)
        self._cache: dict[int, tuple[tuple[int, int], np.ndarray]] = {}

        rng = np.random.default_rng(np.random.SeedSequence([self.seed, 0]))
        f0 = float(rpm) / 60.0
        fl = N_LAMELLAS * f0
        # (frequency, amplitude, phase, modulation depth at f0, modulation phase)
        comps = [
            (f0, rng.uniform(0.40, 0.60)),
            (2 * f0, rng.uniform(0.12, 0.25)),
            (3 * f0, rng.uniform(0.04, 0.12)),
            (fl, rng.uniform(0.40, 0.55)),
            (2 * fl, rng.uniform(0.06, 0.18)),
        ]
        phases = rng.uniform(0.0, 2 * np.pi, size=len(comps))
        mod_depth = rng.uniform(0.15, 0.35)
        mod_phase = rng.uniform(0.0, 2 * np.pi)
        self.i_phase = rng.uniform(0.0, 2 * np.pi)
        self.harmonics = [
            (2 * np.pi * f, a, p, mod_depth if f == fl else 0.0)
            for (f, a), p in zip(comps, phases)
            if f < 0.45 * self.fs
        ]
        self.w0 = 2 * np.pi * f0
        self.wl = 2 * np.pi * fl
        self.mod_phase = mod_phase
        # Everything deterministic is periodic in the rotation: when a
        # revolution is a whole number of samples (240 at 1 kHz), tabulate it.
        period = self.fs * 60.0 / float(rpm)
        self._table: tuple[np.ndarray, np.ndarray] | None = None
        if abs(period - round(period)) < 1e-9 * period and round(period) <= 10_000_000:
            self._table = self._rotor_direct(np.arange(round(period)) / self.fs)

        self.sos_bb, g = _band_sos(5.0, 250.0, self.fs)
        self.g_bb = _BB_STD / g
        self.sos_x, g = _band_sos(2.0, 150.0, self.fs)
        self.g_x = _X_STD / g
        self.sos_r, g = _band_sos(min(150.0, 0.25 * self.fs), 350.0, self.fs)
        self.g_r = _RING_STD / g

        def z(sos: np.ndarray) -> np.ndarray:
            return np.zeros((sos.shape[0], 2))

        self.z_bb, self.z_x = z(self.sos_bb), z(self.sos_x)
        self.z_r = [z(self.sos_r) for _ in range(3)]

    # -- noise, one generator per fixed block ------------------------------
    def _block_noise(self, ns: int, b: int) -> np.ndarray:
        key = (ns, b)
        arr = self._cache.get(ns)
        if arr is None or arr[0] != key:
            ss = np.random.SeedSequence([self.seed, ns, b + _BLOCK_OFFSET])
            arr = (key, np.random.default_rng(ss).standard_normal((_N_STREAMS[ns], self.block)))
            self._cache[ns] = arr
        return arr[1]

    def _noise(self, ns: int, m0: int, n: int) -> np.ndarray:
        out = np.empty((_N_STREAMS[ns], n))
        pos, m, B = 0, m0, self.block
        while pos < n:
            b = m // B
            off = m - b * B
            take = min(B - off, n - pos)
            out[:, pos : pos + take] = self._block_noise(ns, b)[:, off : off + take]
            pos += take
            m += take
        return out

    # -- deterministic rotor excitation --------------------------------------
    def _rotor(self, idx: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Periodic part of fz_d and the current ripple factor at samples idx."""
        if self._table is not None:
            k = idx % self._table[0].size
            return self._table[0][k], self._table[1][k]
        return self._rotor_direct(t)

    def _rotor_direct(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g = np.zeros(t.shape)
        for omega, a, p, depth in self.harmonics:
            comp = a * np.sin(omega * t + p)
            if depth:
                comp *= 1.0 + depth * np.sin(self.w0 * t + self.mod_phase)
            g += comp
        ripple = 1.0 + _RIPPLE_I * np.sin(self.wl * t + self.i_phase)
        return g, ripple

    def channel_names(self) -> tuple[str, ...]:
        return ("fx", "fy", "fz", "i") if self.current_fn is not None else ("fx", "fy", "fz")

    def static(self, t: float) -> dict[str, float]:
        """Noise-free static (DC) level of each force channel at time t."""
        ta = np.array([t])
        c = float(self.loss_fn(ta)[0]) if self.loss_fn is not None else 0.0
        nz = self.n0 * (1.0 - _LOSS_PRELOAD_DROP * c)
        mu = float(self.mu0_fn(ta)[0])
        return {"fx": 0.0, "fy": self.s * mu * nz, "fz": nz}

    def next(self, n: int) -> dict[str, np.ndarray]:
        """The next ``n`` DC-coupled samples of every channel."""
        m0 = self.m
        self.m += n
        idx = np.arange(m0, m0 + n, dtype=np.int64)
        t = idx / self.fs
        w = self._noise(_NS_FORCE, m0, n)

        fz_d, ripple = self._rotor(idx, t)
        bb, self.z_bb = signal.sosfilt(self.sos_bb, w[_S_BB], zi=self.z_bb)
        fz_d = fz_d + self.g_bb * bb
        fz_d = _LIMIT_N * np.tanh(fz_d / _LIMIT_N)

        xb, self.z_x = signal.sosfilt(self.sos_x, w[_S_X], zi=self.z_x)
        fx = _X_COUPLING * fz_d + self.g_x * xb + _NOISE_X * w[_S_EX]

        if self.loss_fn is not None:
            c = self.loss_fn(t)
            normal = np.maximum(self.n0 * (1.0 - _LOSS_PRELOAD_DROP * c) + (1.0 + _LOSS_DYN_GAIN * c) * fz_d, 0.0)
            wr = self._noise(_NS_RING, m0, n)
            ring = []
            for k in range(3):
                r, self.z_r[k] = signal.sosfilt(self.sos_r, wr[k], zi=self.z_r[k])
                ring.append(self.g_r * c * r)
        else:
            normal = self.n0 + fz_d
            ring = None

        mu = self.mu0_fn(t)
        if self.beta != 0.0:
            mu = np.maximum(mu * (1.0 + self.beta * (normal - self.n0) / self.n0), 0.0)
        fy = self.s * (mu * normal) + _NOISE_Y * w[_S_EY]
        fz = normal + _NOISE_Z * w[_S_EZ]
        if ring is not None:
            fx += ring[0]
            fy += ring[1]
            fz += ring[2]
        out = {"fx": fx, "fy": fy, "fz": fz}
        if self.current_fn is not None:
            cur = self.current_fn(t)
            out["i"] = cur * ripple + _NOISE_I * self._noise(_NS_CURRENT, m0, n)[0]
        return out


def _quantise(x: np.ndarray, full_scale: float) -> np.ndarray:
    lsb = 2.0 * full_scale / 2**ADC_BITS
    out: np.ndarray = np.clip(np.round(x / lsb) * lsb, -full_scale, full_scale - lsb)
    return out


class _Acquisition:
    """Skew delay lines, charge-amplifier high-pass and 16-bit converter."""

    def __init__(self, rig: _Rig, *, skew: int, raw: bool) -> None:
        pre = rig.block  # pre-roll length (samples), rig must start at -pre
        if abs(skew) > pre:
            raise ValueError(f"|skew| must be <= {pre} samples, got {skew}")
        self.rig = rig
        self.raw = raw
        self.names = rig.channel_names()
        delay = {c: max(0, -skew) for c in self.names}
        delay["fz"] = max(0, skew)
        first = rig.next(pre)  # engine samples -pre..-1: settle filters, fill delay lines
        self.buf = {c: first[c][pre - delay[c] :].copy() for c in self.names}
        self.sos = signal.butter(HP_ORDER, HP_CUTOFF_HZ, "highpass", fs=rig.fs, output="sos")
        zi = signal.sosfilt_zi(self.sos)
        static = rig.static(0.0)
        self.hp = {c: zi * static[c] for c in ("fx", "fy", "fz")}

    def next(self, n: int) -> dict[str, np.ndarray]:
        new = self.rig.next(n)
        out: dict[str, np.ndarray] = {}
        for c in self.names:
            b = self.buf[c]
            if b.size:
                full = np.concatenate((b, new[c]))
                x, self.buf[c] = full[:n], full[n:]
            else:
                x = new[c]
            if c == "i":
                out[c] = _quantise(x, FULL_SCALE_A)
                continue
            if not self.raw:
                x, self.hp[c] = signal.sosfilt(self.sos, x, zi=self.hp[c])
            out[c] = _quantise(x, FULL_SCALE_N)
        return out


# --------------------------------------------------------------------------
# Helpers
# --------------------------------------------------------------------------
def _check_common(seed: int, fs: float, orientation: int, force_dependence: float, skew: int) -> float:
    """Validate the common options; return fs as a Python float."""
    if not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    if not (fs > 0 and math.isfinite(fs)):
        raise ValueError(f"fs must be positive, got {fs!r}")
    if orientation not in (1, -1):
        raise ValueError(f"orientation must be +1 or -1, got {orientation!r}")
    if not math.isfinite(force_dependence) or force_dependence <= -1.0:
        raise ValueError(f"force_dependence must be > -1, got {force_dependence!r}")
    if not isinstance(skew, (int, np.integer)):
        raise TypeError(f"skew must be an integer number of samples, got {skew!r}")
    return float(fs)


def _record(rig: _Rig, n_total: int, *, skew: int, raw: bool, chunk: int) -> dict[str, np.ndarray]:
    acq = _Acquisition(rig, skew=skew, raw=raw)
    out = {c: np.empty(n_total) for c in acq.names}
    pos = 0
    while pos < n_total:
        k = min(chunk, n_total - pos)
        part = acq.next(k)
        for c in acq.names:
            out[c][pos : pos + k] = part[c]
        pos += k
    return out


@dataclass(frozen=True)
class _ScenarioOptions:
    """The options every recorded scenario takes (``fs`` as returned by :func:`_check_common`)."""

    seed: int
    fs: float
    orientation: int
    force_dependence: float
    skew: int
    raw: bool


def _record_scenario(
    tg: np.ndarray,
    mu: np.ndarray,
    duration: float,
    opts: _ScenarioOptions,
    *,
    loss_fn: _ArrayFn | None = None,
    current_fn: _ArrayFn | None = None,
) -> dict[str, np.ndarray]:
    """Records a scenario whose true COF is ``mu`` on the truth grid ``tg``.

    ``opts`` are the scenario's options; ``loss_fn`` and ``current_fn`` go
    to the rig as they are. The rig starts one second before t = 0 and the
    channels are generated in 60 s chunks (the chunking does not change the
    data).
    """

    def mu0_fn(t: np.ndarray) -> np.ndarray:
        out: np.ndarray = np.interp(t, tg, mu)
        return out

    fs = opts.fs
    rig = _Rig(
        fs=fs,
        seed=int(opts.seed),
        orientation=opts.orientation,
        beta=opts.force_dependence,
        mu0_fn=mu0_fn,
        loss_fn=loss_fn,
        current_fn=current_fn,
        start_index=-max(1, round(fs)),
    )
    n_total = round(duration * fs)
    return _record(rig, n_total, skew=int(opts.skew), raw=opts.raw, chunk=max(1, round(60.0 * fs)))


def _truth_grid(duration: float) -> np.ndarray:
    return np.arange(math.floor(duration / TRUTH_DT + 1e-9) + 1) * TRUTH_DT


def _play(temperature: np.ndarray, half_width: float) -> np.ndarray:
    """Play (backlash) operator, starting on the heating branch."""
    out = np.empty_like(temperature)
    te = float(temperature[0]) - half_width
    for k, tk in enumerate(temperature.tolist()):
        te = min(max(te, tk - half_width), tk + half_width)
        out[k] = te
    return out


# --------------------------------------------------------------------------
# Scenarios
# --------------------------------------------------------------------------
def temperature_test(
    *,
    seed: int = 0,
    fs: float = 1000.0,
    orientation: int = -1,
    force_dependence: float = 0.0,
    skew: int = 0,
    raw: bool = False,
    model: str = "bathtub",
    running_in: float = 0.0,
) -> Simulation:
    """The paper's temperature test (Sec. 4.1, Fig. 10-11): 4060 s.

    The commutator temperature follows ``TEMPERATURE_PATH`` (155 degC for
    1000 s, up to 175 at 2000 s, down to 135 at 3550 s, 130 at 3650 s, 135 at
    3750 s, heating off at 3950 s and 100 degC at 4010 s). The COF ``mu0(t)``
    follows :func:`cof_vs_temperature` with the play operator run along the
    path (hysteresis of the upper edge): optimum 135-160 degC on heating,
    135-155 degC on cooling, about 0.157 at 175 degC, 0.116 at 130 degC and
    about 0.25 at 100 degC. The temperature log is read every
    100-200 s (uniformly random intervals) plus at the end, with 0.3 degC
    reading noise, rounded to 0.1 degC (the rotor stops are not simulated).

    Parameters
    ----------
    seed : int
        Seed of all random parts.
    fs : float
        Sampling rate (Hz).
    orientation : {-1, +1}
        Sign of fy relative to the friction force.
    force_dependence : float
        ``beta`` in ``mu = mu0 (1 + beta (N - N0) / N0)``.
    skew : int
        fz delayed by ``skew`` samples relative to fy/fx (``|skew| <= fs``).
    raw : bool
        Return DC-coupled forces (no high-pass), still quantised.
    model : {"bathtub", "flat"}
        "bathtub" (default): the COF above. "flat": a COF of 0.1 that does
        not depend on the temperature (the same path and log; for false
        optima, issue 23); ``truth.optimum`` is then empty.
    running_in : float
        A running-in on the 155 degC start plateau (issue 35): the COF
        starts ``running_in`` (relative, >= 0) above its value and decays
        exponentially with a time constant of :data:`T_RUNNING_IN_S` (150 s; 2 %
        of it left at 590 s, well before the heating starts at 1000 s). Default 0:
        none. ``truth.params["running_in_end_s"]`` is that 2 % time (0 without).

    Returns
    -------
    Simulation
        Channels fx, fy, fz; ``truth.optimum`` has ``"temperature"``
        (quasistatic, middle of the loop), ``"temperature_heating"`` and
        ``"temperature_cooling"``.
    """
    fs = _check_common(seed, fs, orientation, force_dependence, skew)
    duration = TEMPERATURE_PATH[-1][0]
    bt = np.array([p[0] for p in TEMPERATURE_PATH])
    bT = np.array([p[1] for p in TEMPERATURE_PATH])
    tg = _truth_grid(duration)
    temp = np.interp(tg, bt, bT)
    t_up = _play(temp, _T_PLAY)
    if model not in ("bathtub", "flat"):
        raise ValueError(f"model must be 'bathtub' or 'flat', got {model!r}")
    mu = _mu_of_temperature(temp, t_up) if model == "bathtub" else np.full(tg.shape, _T_MU_MIN)
    if not (isinstance(running_in, (int, float)) and 0.0 <= running_in < 10.0):
        raise ValueError(f"running_in must be in [0, 10), got {running_in!r}")
    if running_in:
        mu = mu * (1.0 + running_in * np.exp(-tg / T_RUNNING_IN_S))
    opts = _ScenarioOptions(seed, fs, orientation, force_dependence, skew, raw)
    channels = _record_scenario(tg, mu, duration, opts)

    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 2]))
    times = [0.0]
    while True:
        nxt = times[-1] + rng.uniform(100.0, 200.0)
        if nxt >= duration:
            break
        times.append(nxt)
    times.append(duration)
    # The operator also reads the temperature whenever the heating programme
    # changes course (the path's breakpoints), as a real test log would; the
    # analysis interpolates the log linearly (docs/method.md 6), which is then
    # exact between readings up to the reading noise.
    times = sorted(set(times) | {float(t) for t, _ in TEMPERATURE_PATH if 0.0 < t < duration})
    log_t = np.unique(np.round(np.array(times), 1))
    log_T = np.round(np.interp(log_t, bt, bT) + rng.normal(0.0, 0.3, size=log_t.size), 1)

    truth = Truth(
        t=tg,
        mu=mu,
        temperature=temp,
        current_density=None,
        contact_loss=(),
        optimum={
            "temperature": (_T_LO, _T_HI),
            "temperature_heating": (_T_LO, _T_HI + _T_PLAY),
            "temperature_cooling": (_T_LO, _T_HI - _T_PLAY),
        }
        if model == "bathtub"
        else {},
        force_dependence=float(force_dependence),
        skew=int(skew),
        params={
            "scenario": "temperature",
            "model": model,
            "preload_N": PRELOAD_N,
            "mu_min": _T_MU_MIN,
            "temperature_path": TEMPERATURE_PATH,
            "hysteresis_play_degC": _T_PLAY,
            "upper_edge_temperature": t_up,
            "running_in": float(running_in),
            "running_in_end_s": T_RUNNING_IN_S * math.log(50.0) if running_in else 0.0,
        },
    )
    return Simulation(
        fs=float(fs),
        channels=channels,
        temperature_log=(log_t, log_T),
        area_mm2=4.0,
        rpm=RPM,
        n_lamellas=N_LAMELLAS,
        orientation=int(orientation),
        truth=truth,
    )


def current_density_test(
    *,
    seed: int = 0,
    fs: float = 1000.0,
    orientation: int = -1,
    force_dependence: float = 0.0,
    skew: int = 0,
    raw: bool = False,
    current_drop: float = 0.0,
    bathtub: str = "paper",
) -> Simulation:
    """The paper's current-density test (Sec. 4.2, Fig. 12): 700 s, 1 mm^2 tip.

    J is stepped 2.0, 2.5, ..., 6.5 A/mm^2, each step lasting 70 s; the current
    channel ``i`` = J x 1 mm^2 (A) with 1 % commutation ripple at f_l and
    0.01 A noise. The COF follows ``cof_vs_current_density(J)`` through a
    first-order lag of 2 s: minimum 0.1 on 4.25-4.75 A/mm^2 (reached in the
    4.5 A/mm^2 step), 0.25 at 6 A/mm^2, 0.30 at 6.5 A/mm^2. From 632 s to the
    end (2 s into the 6.5 A/mm^2 step, 1 s ramp) the contact is lost
    intermittently: the preload collapses, the contact force is often 0 and
    brush ringing dominates, so ``|C_yz| < 0.85`` there. The commutator
    temperature rises linearly from 100 to 135 degC (logged at start and end
    only, as in the paper); it does not enter the COF model.

    Parameters
    ----------
    seed, fs, orientation, force_dependence, skew, raw
        As in :func:`temperature_test`.
    current_drop : float
        Fraction in [0, 1) by which the measured current falls while the
        contact is lost (the burned-out contact conducts less): ``i = J A (1
        - current_drop c(t))`` with the contact-loss level ``c``. Default 0:
        the current is the set point throughout (issue 23: 0.3 makes the
        contact-loss windows read about 4.55 A/mm^2 at the 6.5 step).
    bathtub : {"paper", "curved"}
        "paper" (default): :func:`cof_vs_current_density`. "curved":
        :func:`curved_bathtub` with :data:`CURVED_J` (flat below 3 A/mm^2,
        floor 4.3-4.8); ``truth.optimum`` is then (4.3, 4.8).

    Returns
    -------
    Simulation
        Channels fx, fy, fz, i; ``truth.optimum = {"current_density": (4.25,
        4.75)}``; ``truth.contact_loss = ((632.0, 700.0),)``.
    """
    fs = _check_common(seed, fs, orientation, force_dependence, skew)
    duration = _CD_DURATION
    area = _CD_AREA
    n_steps = round((_CD_J1 - _CD_J0) / _CD_DJ)

    def j_fn(t: np.ndarray) -> np.ndarray:
        k = np.clip(np.floor(np.asarray(t) / _CD_STEP_S + 1e-9), 0, n_steps)
        return _CD_J0 + _CD_DJ * k

    if bathtub not in ("paper", "curved"):
        raise ValueError(f"bathtub must be 'paper' or 'curved', got {bathtub!r}")
    if not (isinstance(current_drop, (int, float)) and 0.0 <= current_drop < 1.0):
        raise ValueError(f"current_drop must be in [0, 1), got {current_drop!r}")
    tg = _truth_grid(duration)
    jg = j_fn(tg)
    target = cof_vs_current_density(jg) if bathtub == "paper" else curved_bathtub(jg, **CURVED_J)
    a = math.exp(-TRUTH_DT / _J_TAU_S)
    mu, _ = signal.lfilter([1.0 - a], [1.0, -a], target, zi=[a * target[0]])

    def loss_fn(t: np.ndarray) -> np.ndarray:
        return np.clip((t - _CD_LOSS_START) / _CD_LOSS_RAMP, 0.0, 1.0)

    def current_fn(t: np.ndarray) -> np.ndarray:
        if current_drop:
            return j_fn(t) * area * (1.0 - current_drop * loss_fn(t))
        return j_fn(t) * area

    opts = _ScenarioOptions(seed, fs, orientation, force_dependence, skew, raw)
    channels = _record_scenario(tg, mu, duration, opts, loss_fn=loss_fn, current_fn=current_fn)

    temp = 100.0 + 35.0 * tg / duration
    truth = Truth(
        t=tg,
        mu=mu,
        temperature=temp,
        current_density=jg,
        contact_loss=((_CD_LOSS_START, duration),),
        optimum={"current_density": _J_OPT if bathtub == "paper" else (CURVED_J["lo"], CURVED_J["hi"])},
        force_dependence=float(force_dependence),
        skew=int(skew),
        params={
            "scenario": "current_density",
            "preload_N": PRELOAD_N,
            "mu_min": float(_J_MU.min()),
            "j_steps": tuple(_CD_J0 + _CD_DJ * k for k in range(n_steps + 1)),
            "step_s": _CD_STEP_S,
            "cof_time_constant_s": _J_TAU_S,
            "bathtub": bathtub,
            "current_drop": float(current_drop),
            "instability_onset": _CD_J1,
        },
    )
    return Simulation(
        fs=float(fs),
        channels=channels,
        temperature_log=(np.array([0.0, duration]), np.array([100.0, 135.0])),
        area_mm2=area,
        rpm=RPM,
        n_lamellas=N_LAMELLAS,
        orientation=int(orientation),
        truth=truth,
    )


def continuous(
    duration_s: float,
    *,
    chunk_s: float = 60.0,
    mu: float = 0.12,
    current: float | None = None,
    seed: int = 0,
    fs: float = 1000.0,
    orientation: int = -1,
    force_dependence: float = 0.0,
    skew: int = 0,
    raw: bool = False,
) -> Iterator[dict[str, np.ndarray]]:
    """A long stationary recording, generated and yielded chunk by chunk.

    Memory is bounded by the chunk. The data do not depend on ``chunk_s``:
    concatenating the chunks of two calls with different ``chunk_s`` (same
    other arguments) gives identical arrays.

    Parameters
    ----------
    duration_s : float
        Length of the recording (s); ``round(duration_s * fs)`` samples.
    chunk_s : float
        Length of each yielded chunk (s), ``round(chunk_s * fs)`` samples;
        the last chunk may be shorter.
    mu : float
        Constant true COF ``mu0``.
    current : float or None
        Constant current (A) for an ``"i"`` channel; None for no channel.
    seed, fs, orientation, force_dependence, skew, raw
        As in :func:`temperature_test`.

    Yields
    ------
    dict
        Role -> float64 array: ``"fx"``, ``"fy"``, ``"fz"`` (and ``"i"``).
    """
    fs = _check_common(seed, fs, orientation, force_dependence, skew)
    if not duration_s >= 0:
        raise ValueError(f"duration_s must be >= 0, got {duration_s!r}")
    chunk = round(float(chunk_s) * fs)
    if chunk < 1:
        raise ValueError(f"chunk_s * fs must be >= 1 sample, got {chunk_s!r}")
    mu_c = float(mu)

    def mu0_fn(t: np.ndarray) -> np.ndarray:
        return np.full(np.shape(t), mu_c)

    current_fn: _ArrayFn | None = None
    if current is not None:
        cur_c = float(current)

        def constant_current(t: np.ndarray) -> np.ndarray:
            return np.full(np.shape(t), cur_c)

        current_fn = constant_current

    rig = _Rig(
        fs=fs,
        seed=int(seed),
        orientation=orientation,
        beta=force_dependence,
        mu0_fn=mu0_fn,
        current_fn=current_fn,
        start_index=-max(1, round(fs)),
    )
    n_total = round(float(duration_s) * fs)

    def gen() -> Iterator[dict[str, np.ndarray]]:
        acq = _Acquisition(rig, skew=int(skew), raw=raw)
        pos = 0
        while pos < n_total:
            k = min(chunk, n_total - pos)
            yield acq.next(k)
            pos += k

    return gen()


# --------------------------------------------------------------------------
# Stationary recording under controlled measurement conditions (issue 12)
# --------------------------------------------------------------------------
_NS_CONDITIONS = 12  # SeedSequence([seed, 12]); the rig uses [seed, 0] and 3-entry keys
_COND_PAD_S = 2.0  # pad at each end of the generated record (s)
_COND_BAND_HZ = (20.0, 200.0)  # band of the "band" noises
_COND_DRIFT_HZ = 2.0  # low-pass corner of the fy disturbance
_COND_NOISE_KINDS = ("white", "band")


def _cond_number(name: str, value: Any, *, nonneg: bool = False) -> float:
    """``value`` as a finite float (>= 0 when ``nonneg``), else ValueError."""
    if isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if nonneg and v < 0.0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    return v


def _cond_kind(name: str, kind: Any) -> str:
    if not isinstance(kind, str) or kind not in _COND_NOISE_KINDS:
        raise ValueError(f"unknown {name} {kind!r}; choose 'white' or 'band'")
    return kind


def _cond_unit(w: np.ndarray, sos: np.ndarray | None, keep: slice) -> np.ndarray:
    """``w`` filtered by ``sos`` (if any), scaled to unit std over ``keep``."""
    x = signal.sosfilt(sos, w) if sos is not None else w
    s = float(np.std(x[keep]))
    return x / s if s > 0.0 else x


def _fractional_delay(x: np.ndarray, d: float) -> np.ndarray:
    """``x`` delayed by ``d`` samples (band-limited): ``out[n] = x(n - d)``.

    The straight line through the end points is removed and shifted
    analytically; the remainder (zero at both ends) is shifted by
    ``exp(-2j pi f d)`` on a zero-padded FFT. Only the ends of the record
    (the caller's pads) see the circular wrap.
    """
    from scipy import fft as sfft

    size = x.size
    n = np.arange(size, dtype=np.float64)
    slope = (x[-1] - x[0]) / (size - 1) if size > 1 else 0.0
    line = x[0] + slope * n
    m = sfft.next_fast_len(size, real=True)
    spec = sfft.rfft(x - line, n=m)
    spec *= np.exp(-2j * np.pi * np.fft.rfftfreq(m) * d)
    out: np.ndarray = sfft.irfft(spec, n=m)[:size] + (x[0] + slope * (n - d))
    return out


@dataclass(frozen=True)
class _Conditions:
    """The measurement conditions of :func:`conditions`, checked: numbers as floats, noise kinds known.

    ``n_out`` is the record's length in samples; ``rpm`` the rig's speed
    (:data:`RPM` when none is given).
    """

    duration: float
    n_out: int
    mu: float
    snr_z: float | None
    z_noise: str
    y_noise: float
    y_noise_kind: str
    drift: float
    ripple: float
    delay: float
    beta: float
    rpm: float


def _check_conditions(
    duration_s: float,
    fs: float,
    *,
    mu: float,
    snr_z: float | None,
    z_noise: str,
    y_noise: float,
    y_noise_kind: str,
    drift: float,
    ripple: float,
    delay: float,
    beta: float,
    raw: bool,
    rpm: float | None,
) -> _Conditions:
    """The arguments of :func:`conditions` checked (``fs`` as returned by :func:`_check_common`), else ValueError."""
    duration = _cond_number("duration_s", duration_s, nonneg=True)
    n_out = round(duration * fs)
    if n_out < 2:
        raise ValueError(f"duration_s * fs must give >= 2 samples, got {duration_s!r}")
    mu_c = _cond_number("mu", mu, nonneg=True)
    snr = None if snr_z is None else _cond_number("snr_z", snr_z)
    z_kind = _cond_kind("z_noise", z_noise)
    y_kind = _cond_kind("y_noise_kind", y_noise_kind)
    y_std = _cond_number("y_noise", y_noise, nonneg=True)
    drift_std = _cond_number("drift", drift, nonneg=True)
    ripple_c = _cond_number("ripple", ripple, nonneg=True)
    delay_c = _cond_number("delay", delay)
    beta_c = _cond_number("beta", beta)
    speed = RPM if rpm is None else _cond_number("rpm", rpm)
    if not speed > 0.0:
        raise ValueError(f"rpm must be > 0, got {rpm!r}")
    pre = max(1, round(fs))
    if abs(delay_c) > pre:
        raise ValueError(f"|delay| must be <= {pre} samples, got {delay!r}")
    if not isinstance(raw, (bool, np.bool_)):
        raise ValueError(f"raw must be a bool, got {raw!r}")
    return _Conditions(
        duration=duration, n_out=n_out, mu=mu_c, snr_z=snr, z_noise=z_kind, y_noise=y_std, y_noise_kind=y_kind,
        drift=drift_std, ripple=ripple_c, delay=delay_c, beta=beta_c, rpm=speed,
    )  # fmt: skip


def _cond_contact(
    n_tot: int, *, fs: float, seed: int, rpm: float, settle: int, pad: int
) -> tuple[np.ndarray, np.ndarray]:
    """The rig's DC-coupled fz (the true contact force N) and fx over a record of ``n_tot`` samples.

    The rig (orientation +1, no force dependence) settles for ``settle``
    samples, which are discarded; sample n of the record is rig index
    n - ``pad``. Generated in 60 s chunks.
    """

    def ones(t: np.ndarray) -> np.ndarray:
        return np.ones(np.shape(t))

    rig = _Rig(fs=fs, seed=int(seed), orientation=1, beta=0.0, mu0_fn=ones, start_index=-(settle + pad), rpm=rpm)
    rig.next(settle)
    normal = np.empty(n_tot)
    fx = np.empty(n_tot)
    step = max(1, round(60.0 * fs))
    for pos in range(0, n_tot, step):
        part = rig.next(min(step, n_tot - pos))
        normal[pos : pos + part["fz"].size] = part["fz"]
        fx[pos : pos + part["fx"].size] = part["fx"]
    return normal, fx


def conditions(
    duration_s: float,
    *,
    mu: float = 0.1,
    seed: int = 0,
    fs: float = 1000.0,
    orientation: int = -1,
    snr_z: float | None = None,
    z_noise: str = "white",
    y_noise: float = 0.0,
    y_noise_kind: str = "white",
    drift: float = 0.0,
    ripple: float = 0.0,
    delay: float = 0.0,
    beta: float = 0.0,
    raw: bool = False,
    rpm: float | None = None,
) -> Simulation:
    """A stationary recording under controlled measurement conditions.

    The true contact force ``N`` is the rig's DC-coupled fz (mean about the
    preload ``N0 = PRELOAD_N``); the friction force, the noises, the delay
    and the amplifier are applied to the whole record as described in the
    module docstring ("Measurement conditions"). Sample ``n`` is at
    ``n / fs`` (the rig runs 1 s of settling and a 2 s pad before t = 0).
    Deterministic for a seed; about a second per 1000 s at 1 kHz.

    Parameters
    ----------
    duration_s : float
        Length of the recording (s); ``round(duration_s * fs) >= 2`` samples.
    mu : float
        True COF at the preload (constant, >= 0).
    seed : int
        Seed of all random parts (the rig's and ``(seed, 12)``).
    fs : float
        Sampling rate (Hz).
    orientation : {-1, +1}
        Sign of fy relative to the friction force.
    snr_z : float or None
        SNR of fz (dB): extra measurement noise on fz (not contact force) of
        std ``std(N - mean N) * 10**(-snr_z / 20)``; None for none.
    z_noise : {"white", "band"}
        Kind of the fz noise: white, or a 2nd-order Butterworth band-pass
        20-200 Hz.
    y_noise : float
        Std (N) of extra noise on fy, >= 0.
    y_noise_kind : {"white", "band"}
        Kind of the fy noise (same band as ``z_noise``).
    drift : float
        Std (N) of a low-frequency disturbance on fy (white noise through a
        2nd-order Butterworth low-pass at 2 Hz), >= 0. The std is that before
        the 0.1 Hz high-pass, which removes a few per cent of it.
    ripple : float
        Relative friction ripple ``r`` at ``f_l``:
        ``mu(t) = mu (1 + r sin(2 pi f_l t + phi))``, >= 0.
    delay : float
        Samples (fractional, either sign) by which the measured fz is delayed
        relative to fy/fx: ``fz[n] = N(n - delay)``; ``|delay| <= fs``. The
        lag of max ``|C(fy, fz)|`` is ``round(delay)``.
    beta : float
        Force dependence per newton: ``mu(N) = mu (1 + beta (N - N0))``, so
        ``d mu / d N = mu * beta``.
    raw : bool
        Return DC-coupled forces (no high-pass), still quantised.
    rpm : float or None
        Speed of the rig (rev/min, > 0); None: :data:`RPM`. The run-out and
        the lamella excitation (``f_l = N_LAMELLAS rpm / 60``) move with it,
        and so does the autocorrelation of fz at a given lag (at 228 rpm fz
        lagged by 200 samples is nearly uncorrelated with fz, docs/method.md 3b).

    Returns
    -------
    Simulation
        Channels fx, fy, fz; ``rpm`` is the rig's speed. ``truth.mu`` is ``mu`` (constant),
        ``truth.force_dependence`` is ``beta`` per newton (not relative to
        ``N0`` as in the other scenarios), ``truth.skew`` is
        ``int(round(delay))``; ``truth.params`` holds every condition plus
        ``"noise_z_std"`` (std of the fz noise actually added, N),
        ``"dmu_dfn"`` (``mu * beta``), ``"ripple_phase"`` and ``"f_l"``.

    Raises
    ------
    ValueError
        Unknown noise kind, negative std/ripple/mu, non-finite values,
        ``|delay| > fs`` or too short a record.
    """
    fs = _check_common(seed, fs, orientation, 0.0, 0)
    c = _check_conditions(
        duration_s, fs, mu=mu, snr_z=snr_z, z_noise=z_noise, y_noise=y_noise, y_noise_kind=y_noise_kind,
        drift=drift, ripple=ripple, delay=delay, beta=beta, raw=raw, rpm=rpm,
    )  # fmt: skip
    pre = max(1, round(fs))
    # The rig settles for 1 s (discarded), then the record is generated with
    # a pad of 2 s at each end: sample n of the result is rig index n.
    pad = max(1, round(_COND_PAD_S * fs))
    n_tot = c.n_out + 2 * pad
    normal, fx = _cond_contact(n_tot, fs=fs, seed=seed, rpm=c.rpm, settle=pre, pad=pad)
    keep = slice(pad, pad + c.n_out)
    t = (np.arange(n_tot, dtype=np.float64) - pad) / fs

    rng = np.random.default_rng(np.random.SeedSequence([int(seed), _NS_CONDITIONS]))
    phi = float(rng.uniform(0.0, 2.0 * np.pi))
    w_z = rng.standard_normal(n_tot)
    w_y = rng.standard_normal(n_tot)
    w_d = rng.standard_normal(n_tot)
    sos_band = _band_sos(*_COND_BAND_HZ, fs)[0]
    f_l = N_LAMELLAS * c.rpm / 60.0

    mu_t = c.mu * (1.0 + c.beta * (normal - PRELOAD_N))
    if c.ripple != 0.0:
        mu_t = mu_t * (1.0 + c.ripple * np.sin(2.0 * np.pi * f_l * t + phi))
    fy = float(orientation) * np.maximum(mu_t, 0.0) * normal
    if c.y_noise > 0.0:
        fy += c.y_noise * _cond_unit(w_y, sos_band if c.y_noise_kind == "band" else None, keep)
    if c.drift > 0.0:
        sos_lp = signal.butter(2, min(_COND_DRIFT_HZ, 0.4 * fs), "lowpass", fs=fs, output="sos")
        fy += c.drift * _cond_unit(w_d, sos_lp, keep)

    fz = _fractional_delay(normal, c.delay) if c.delay != 0.0 else normal.copy()
    noise_z_std = 0.0
    if c.snr_z is not None:
        e_z = float(np.std(normal[keep])) * 10.0 ** (-c.snr_z / 20.0)
        e_z = e_z * _cond_unit(w_z, sos_band if c.z_noise == "band" else None, keep)
        fz += e_z
        noise_z_std = float(np.std(e_z[keep]))

    channels = _cond_amplifier({"fx": fx, "fy": fy, "fz": fz}, fs, raw=raw, settled=min(pre, pad), keep=keep)
    truth = _cond_truth(c, seed=seed, fs=fs, orientation=orientation, raw=raw, noise_z_std=noise_z_std, phi=phi,
                        f_l=f_l)  # fmt: skip
    return Simulation(
        fs=float(fs),
        channels=channels,
        temperature_log=None,
        area_mm2=None,
        rpm=c.rpm,
        n_lamellas=N_LAMELLAS,
        orientation=int(orientation),
        truth=truth,
    )


def _cond_amplifier(
    forces: dict[str, np.ndarray], fs: float, *, raw: bool, settled: int, keep: slice
) -> dict[str, np.ndarray]:
    """The channels as recorded: each force through the amplifier's high-pass (started at the mean of its first
    ``settled`` samples; none when ``raw``), cut to ``keep`` and quantised."""
    channels: dict[str, np.ndarray] = {}
    sos_hp = signal.butter(HP_ORDER, HP_CUTOFF_HZ, "highpass", fs=fs, output="sos")
    zi = signal.sosfilt_zi(sos_hp)
    for name, x in forces.items():
        if not raw:
            static = float(np.mean(x[:settled]))
            x = signal.sosfilt(sos_hp, x, zi=zi * static)[0]
        channels[name] = _quantise(x[keep], FULL_SCALE_N)
    return channels


def _cond_truth(
    c: _Conditions, *, seed: int, fs: float, orientation: int, raw: bool, noise_z_std: float, phi: float, f_l: float
) -> Truth:
    """The truth of :func:`conditions`: the constant COF, the force dependence, the skew and every condition."""
    tg = _truth_grid(c.duration)
    return Truth(
        t=tg,
        mu=np.full(tg.shape, c.mu),
        temperature=None,
        current_density=None,
        contact_loss=(),
        optimum={},
        force_dependence=c.beta,
        skew=int(round(c.delay)),
        params={
            "scenario": "conditions",
            "preload_N": PRELOAD_N,
            "mu": c.mu,
            "seed": int(seed),
            "fs": fs,
            "orientation": int(orientation),
            "snr_z": c.snr_z,
            "z_noise": c.z_noise,
            "y_noise": c.y_noise,
            "y_noise_kind": c.y_noise_kind,
            "drift": c.drift,
            "ripple": c.ripple,
            "delay": c.delay,
            "beta": c.beta,
            "raw": bool(raw),
            "noise_z_std": noise_z_std,
            "dmu_dfn": c.mu * c.beta,
            "ripple_phase": phi,
            "f_l": f_l,
            "noise_band_hz": _COND_BAND_HZ,
            "drift_cutoff_hz": _COND_DRIFT_HZ,
            "rpm": c.rpm,
        },
    )


def acquisitions(count: int, duration_s: float, *, seed: int = 0, **kw: Any) -> list[Simulation]:
    """``count`` separate acquisitions of ``duration_s`` each under the same :func:`conditions`.

    Acquisition ``k`` is ``conditions(duration_s, seed=seed * 1000 + k, **kw)``
    (``count <= 1000``): its own rig phases, noises and amplifier start, as
    separate short records of one contact are (analyse
    ``[dict(a.channels) for a in result]``; each acquisition is windowed on its own).
    """
    n = int(count)
    if isinstance(count, bool) or n != count or not 1 <= n <= 1000:
        raise ValueError(f"count must be an integer in 1..1000, got {count!r}")
    return [conditions(duration_s, seed=int(seed) * 1000 + k, **kw) for k in range(n)]


_SCENARIOS: dict[str, Callable[..., Simulation]] = {
    "temperature": temperature_test,
    "temperature_test": temperature_test,
    "current_density": current_density_test,
    "current-density": current_density_test,
    "current_density_test": current_density_test,
    "current": current_density_test,
}


def scenario(name: str, **kw: Any) -> Simulation:
    """Run a named scenario: ``"temperature"`` or ``"current_density"``.

    Parameters
    ----------
    name : str
        ``"temperature"`` or ``"current_density"`` (also ``"current-density"``).
    **kw
        Keyword options of the scenario (seed, fs, orientation,
        force_dependence, skew, raw).

    Returns
    -------
    Simulation
    """
    try:
        fn = _SCENARIOS[name.strip().lower()]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; choose 'temperature' or 'current_density'") from None
    return fn(**kw)


@dataclass(frozen=True)
class ReciprocatingSimulation:
    """A simulated reciprocating (ball-on-flat) test: :func:`reciprocating`.

    Attributes
    ----------
    channels : dict of str -> ndarray
        ``fy`` (signed friction, N), ``fz`` (normal force, N), ``x`` (position, m), ``v`` (velocity, m/s).
    fs : float
        Sampling rate, Hz.
    mu_forward, mu_backward : float
        The true COF in the +x and -x directions (the kinetic plateau).
    n_strokes : int
        Strokes simulated (two per cycle).
    energy_per_cycle : float
        The energy friction dissipates in one whole cycle (J): the noise-free friction's loop area.
    offset : float
        The load-cell offset added to fy (N).
    mu_static_forward, mu_static_backward : float
        The static (breakaway) COF: the maximum of the noise-free friction over the load in the first
        quarter of a forward (backward) stroke, after its motion onset (docs/method.md 6c).
    slip_times : ndarray
        Times (s) of the stick-slip drops in the record (empty without stick-slip).
    slip_drops : ndarray
        The friction force's drop (N) at each of them (docs/method.md 6g).
    """

    channels: dict[str, np.ndarray]
    fs: float
    mu_forward: float
    mu_backward: float
    n_strokes: int
    energy_per_cycle: float = float("nan")
    offset: float = 0.0
    mu_static_forward: float = float("nan")
    mu_static_backward: float = float("nan")
    slip_times: np.ndarray = field(default_factory=lambda: np.zeros(0))
    slip_drops: np.ndarray = field(default_factory=lambda: np.zeros(0))


def reciprocating(
    *,
    seed: int = 0,
    fs: float = 1000.0,
    stroke_length: float = 0.01,
    frequency: float = 2.0,
    cycles: int = 20,
    mu_forward: float = 0.12,
    mu_backward: float = 0.10,
    normal_force: float = 10.0,
    noise: float = 0.02,
    fz_dynamic: float = 0.0,
    offset: float = 0.0,
    breakaway: float = 0.0,
    breakaway_time: float = 0.01,
    stick_slip: float = 0.0,
    stick_slip_period: float = 0.025,
) -> ReciprocatingSimulation:
    """A reciprocating test (docs/method.md 6c): sinusoidal position x = L/2 sin(2 pi f t), dead-weight fz.

    Friction is +sign(v) mu_dir fz (mu_forward while v > 0, mu_backward while v < 0), smoothed over
    the reversals by tanh(v / 5 % of the peak speed); fy and fz carry Gaussian noise of ``noise`` N.
    ``fz_dynamic`` > 0 adds a dynamic part to the normal force (the friction follows it):
    ``fz_dynamic (sin(2 pi 37 t) + 0.5 sin(2 pi 61 t + 1))`` N, for the direction-rectified
    regression (docs/method.md 6c). ``offset`` (N) is a load-cell offset added to fy; the result's
    ``energy_per_cycle`` is the noise-free friction's loop area (J).

    Breakaway and stick-slip (docs/method.md 6c, 6g), with tau the time since the stroke's motion
    onset (the last reversal, where v changed sign): the friction force is
    ``tanh(v / 0.05 v_max) (mu(tau) load + stick_slip saw(tau))`` with
    ``mu(tau) = mu_dir + breakaway (tau / t_b) exp(1 - tau / t_b)`` (a static peak about
    ``breakaway`` above the plateau, ``breakaway_time`` t_b after the onset) and the saw-tooth
    ``saw(tau) = frac(tau / P) - 1/2`` (P = ``stick_slip_period``): the force rises slowly by
    ``stick_slip`` N over P and drops by that at once at tau = P, 2P, ... within the stroke. The
    truth (``mu_static_*``, ``slip_times``, ``slip_drops``) comes from the noise-free friction; the
    SNR of the stick-slip is ``20 log10(stick_slip / noise)`` dB (20 dB: ``stick_slip = 10 noise``).
    """
    if not (breakaway >= 0 and breakaway_time > 0 and stick_slip >= 0 and stick_slip_period > 0):
        raise ValueError("breakaway and stick_slip must be >= 0, breakaway_time and stick_slip_period > 0")
    rng = np.random.default_rng(seed)
    n = int(round(cycles / frequency * fs))
    t = np.arange(n) / fs
    w = 2 * np.pi * frequency
    vmax = 0.5 * stroke_length * w
    half = 0.5 / frequency  # a stroke

    def friction_cof(tt: np.ndarray) -> np.ndarray:
        """The noise-free friction force over the load (signed), and the saw-tooth's force separately."""
        vv = vmax * np.cos(w * tt)
        tau = np.mod(tt - 0.5 * half, half)  # reversals at (2j + 1) / (4 f)
        mu_t = np.where(vv > 0, mu_forward, mu_backward) + breakaway * (tau / breakaway_time) * np.exp(
            1.0 - tau / breakaway_time
        )
        return np.asarray(np.tanh(vv / (0.05 * vmax)) * mu_t)

    def saw_force(tt: np.ndarray) -> np.ndarray:
        vv = vmax * np.cos(w * tt)
        tau = np.mod(tt - 0.5 * half, half)
        return np.asarray(np.tanh(vv / (0.05 * vmax)) * stick_slip * (np.mod(tau / stick_slip_period, 1.0) - 0.5))

    x = 0.5 * stroke_length * np.sin(w * t)
    v = vmax * np.cos(w * t)
    load = normal_force + fz_dynamic * (np.sin(2 * np.pi * 37.0 * t) + 0.5 * np.sin(2 * np.pi * 61.0 * t + 1.0))
    fz = load + noise * rng.standard_normal(n)
    fy = friction_cof(t) * load + offset + noise * rng.standard_normal(n)
    if stick_slip > 0:
        fy = fy + saw_force(t)
    # the loop area of the noise-free friction over one period, finely sampled (a dead weight: load constant)
    tf = np.linspace(0.0, 1.0 / frequency, 200_001)
    vf = vmax * np.cos(w * tf)
    ff = friction_cof(tf) * normal_force + (saw_force(tf) if stick_slip > 0 else 0.0)
    p = ff * vf
    energy = float(np.sum(0.5 * (p[1:] + p[:-1]) * np.diff(tf)))  # the trapezoid rule
    # the static COF: the largest noise-free |friction| / load in the first quarter of a stroke
    statics = []
    for onset in (-0.5 * half, 0.5 * half):  # a forward stroke, then a backward one
        tq = onset + np.linspace(0.0, 0.25 * half, 100_001)[1:]
        fq = friction_cof(tq) * normal_force + (saw_force(tq) if stick_slip > 0 else 0.0)
        statics.append(float(np.max(np.abs(fq))) / normal_force)
    # the drops: P, 2P, ... after every onset, within its stroke and the record
    times: list[float] = []
    if stick_slip > 0:
        onsets = (np.arange(-1, 2 * cycles + 1) + 0.5) * half
        per = np.arange(1, int(np.ceil(half / stick_slip_period)) + 1) * stick_slip_period
        per = per[per < half * (1 - 1e-9)]
        td_all = (onsets[:, None] + per[None, :]).ravel()
        times = sorted(float(u) for u in td_all if 0.0 < u < n / fs)
    slip_t = np.asarray(times, dtype=float)
    slip_d = np.abs(np.tanh(vmax * np.cos(w * slip_t) / (0.05 * vmax))) * stick_slip
    return ReciprocatingSimulation({"fy": fy, "fz": fz, "x": x, "v": v}, float(fs), mu_forward, mu_backward,
                                   2 * cycles, energy, float(offset), statics[0], statics[1], slip_t,
                                   slip_d)  # fmt: skip


# --------------------------------------------------------------------------
# Stribeck curve: a speed sweep under a dead weight (docs/method.md 7a)
# --------------------------------------------------------------------------
@dataclass(frozen=True)
class StribeckModel:
    """The COF against sliding speed of :func:`stribeck_sweep` (docs/method.md 7a).

    ``mu(v) = mu_c + (mu_s - mu_c) exp(-(v / v_s)^2) + k v`` for the sliding
    speed ``v >= 0`` (m/s): the boundary COF ``mu_s`` at low speed, falling
    around the Stribeck speed ``v_s`` towards ``mu_c`` as a lubricant film
    builds up (mixed lubrication), and a viscous rise ``k v`` once the film
    carries the load (hydrodynamic lubrication).

    Attributes
    ----------
    mu_s : float
        Boundary (static-limit) COF, ``mu(0)``.
    mu_c : float
        The COF the film would leave without viscous losses (below ``mu_s``).
    v_s : float
        Stribeck speed, m/s.
    k : float
        Viscous slope, COF per m/s (>= 0).
    """

    mu_s: float = 0.15
    mu_c: float = 0.06
    v_s: float = 0.01
    k: float = 0.05

    def mu(self, v: Any) -> np.ndarray:
        """The COF at sliding speeds ``v`` (m/s; the magnitude is used)."""
        v = np.abs(np.asarray(v, dtype=np.float64))
        out: np.ndarray = self.mu_c + (self.mu_s - self.mu_c) * np.exp(-((v / self.v_s) ** 2)) + self.k * v
        return out

    @property
    def v_min(self) -> float:
        """Speed of the lowest COF (m/s): the mixed-to-hydrodynamic transition; inf when ``k = 0``.

        Where ``d mu / d v = 0``: ``2 (mu_s - mu_c) (v / v_s^2) exp(-(v / v_s)^2) = k``, the root
        beyond ``v_s / sqrt 2`` (where the fall is steepest), found by bisection.
        """
        if self.k <= 0:
            return math.inf
        a = self.mu_s - self.mu_c

        def slope(v: float) -> float:
            return self.k - 2.0 * a * v / self.v_s**2 * math.exp(-((v / self.v_s) ** 2))

        lo = self.v_s / math.sqrt(2.0)
        if slope(lo) >= 0:  # the viscous rise outweighs the fall everywhere: the minimum is at rest
            return 0.0
        hi = lo
        while slope(hi) < 0:
            hi *= 2.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if slope(mid) < 0 else (lo, mid)
        return 0.5 * (lo + hi)

    @property
    def mu_min(self) -> float:
        """The lowest COF, ``mu(v_min)``."""
        return float(self.mu(self.v_min)) if math.isfinite(self.v_min) else self.mu_c

    @property
    def v_boundary(self) -> float:
        """End of the boundary regime (m/s): where the COF has fallen by 10 % of ``mu_s - mu_c``.

        ``exp(-(v / v_s)^2) = 0.9``, so ``v = v_s sqrt(ln(10 / 9))`` (the viscous term aside).
        """
        return self.v_s * math.sqrt(math.log(10.0 / 9.0))


@dataclass(frozen=True)
class StribeckSimulation:
    """A simulated Stribeck test: :func:`stribeck_sweep`.

    Attributes
    ----------
    channels : dict of str -> ndarray
        ``fy`` (friction, N), ``fz`` (normal force, N), ``v`` (measured sliding velocity, m/s).
    fs : float
        Sampling rate, Hz.
    model : StribeckModel
        The true COF against speed.
    speed_log : (t_s, v_m_s)
        The set speed once a second, as a test controller logs it (for ``covariates={"speed": ...}``).
    t, speed, mu : ndarray
        Truth on a ``TRUTH_DT`` grid: the set speed and the model's COF there.
    normal_force : float
        The dead weight, N.
    params : dict
        Every setting of the simulation.
    """

    channels: dict[str, np.ndarray]
    fs: float
    model: StribeckModel
    speed_log: tuple[np.ndarray, np.ndarray]
    t: np.ndarray
    speed: np.ndarray
    mu: np.ndarray
    normal_force: float
    params: Mapping[str, Any] = field(default_factory=dict)

    def mu_at(self, times: Any) -> np.ndarray:
        """The model's COF at ``times`` (s), from the set speed there; NaN outside the test."""
        out: np.ndarray = np.interp(np.asarray(times, dtype=float), self.t, self.mu, left=np.nan, right=np.nan)
        return out

    def speed_at(self, times: Any) -> np.ndarray:
        """The set speed (m/s) at ``times`` (s); NaN outside the test."""
        out: np.ndarray = np.interp(np.asarray(times, dtype=float), self.t, self.speed, left=np.nan, right=np.nan)
        return out


def _set_speed(t: np.ndarray, duration: float, lo: float, hi: float, steps: int) -> np.ndarray:
    """Log-uniform speed: a continuous ramp (``steps = 0``) or ``steps`` equal dwells, lowest first."""
    frac = np.clip(t / duration, 0.0, 1.0)
    if steps:
        frac = np.minimum(np.floor(frac * steps), steps - 1) / max(steps - 1, 1)
    out: np.ndarray = lo * (hi / lo) ** frac
    return out


def stribeck_sweep(
    *,
    seed: int = 0,
    fs: float = 100.0,
    duration: float = 600.0,
    speeds: tuple[float, float] = (1e-3, 1.0),
    steps: int = 0,
    normal_force: float = 10.0,
    model: StribeckModel | None = None,
    noise: float = 0.02,
    speed_noise: float = 0.005,
    scatter: float = 0.002,
) -> StribeckSimulation:
    """A pin-on-disc test under a dead weight whose sliding speed sweeps decades (docs/method.md 7a).

    The set speed rises log-uniformly from ``speeds[0]`` to ``speeds[1]`` (m/s) over ``duration``
    seconds: continuously (``steps=0``) or in ``steps`` equal dwells. The friction force is
    ``fy = (mu(v) + e(t)) W + n_y`` with the dead weight ``W = normal_force`` (N), the COF ``mu(v)``
    of ``model`` (:class:`StribeckModel`, default ``mu_s = 0.15, mu_c = 0.06, v_s = 0.01 m/s,
    k = 0.05 s/m``: minimum 0.0614 at 0.0262 m/s), ``e(t)`` a slow COF scatter (white noise through a
    1st-order Butterworth low-pass at 0.1 Hz, std ``scatter``) and ``n_y`` white sensor noise of
    ``noise`` N; ``fz = W + n_z`` (the same noise). The measured velocity is the set speed times
    ``1 + speed_noise * white``. The COF follows the speed at once (no film dynamics).
    Deterministic for a seed; 60 000 samples by default.

    Raises
    ------
    ValueError
        A non-finite or out-of-range setting (speeds must satisfy 0 < lo < hi; steps 0 or >= 2).
    """
    m = StribeckModel() if model is None else model
    fs_v = _cond_number("fs", fs)
    dur = _cond_number("duration", duration)
    if not (fs_v > 0 and dur > 0):
        raise ValueError(f"fs and duration must be > 0, got fs={fs!r}, duration={duration!r}")
    try:
        lo, hi = (float(s) for s in speeds)
    except (TypeError, ValueError):
        raise ValueError(f"speeds must be (lowest, highest) in m/s, got {speeds!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"speeds must satisfy 0 < lowest < highest, got {speeds!r}")
    if isinstance(steps, bool) or not isinstance(steps, (int, np.integer)) or steps == 1 or steps < 0:
        raise ValueError(f"steps must be 0 (a continuous ramp) or an integer >= 2, got {steps!r}")
    w = _cond_number("normal_force", normal_force)
    if not w > 0:
        raise ValueError(f"normal_force must be > 0, got {normal_force!r}")
    noise, speed_noise, scatter = (_cond_number(name, value, nonneg=True) for name, value in (
        ("noise", noise), ("speed_noise", speed_noise), ("scatter", scatter)))  # fmt: skip
    for name in ("mu_s", "mu_c", "v_s", "k"):
        _cond_number(f"model.{name}", getattr(m, name), nonneg=True)
    if not (m.v_s > 0 and m.mu_s >= m.mu_c):
        raise ValueError(f"the model needs v_s > 0 and mu_s >= mu_c, got {m!r}")
    n = int(round(dur * fs_v))
    if n < 2:
        raise ValueError(f"duration * fs must give >= 2 samples, got {n}")
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 24]))
    t = np.arange(n) / fs_v
    v_set = _set_speed(t, dur, lo, hi, int(steps))
    e = rng.standard_normal(n)
    if scatter > 0:
        sos = signal.butter(1, min(0.1, 0.4 * fs_v), "lowpass", fs=fs_v, output="sos")
        e = signal.sosfilt(sos, e)
        e = scatter * (e - e.mean()) / e.std()
    else:
        e = np.zeros(n)
    fy = (m.mu(v_set) + e) * w + noise * rng.standard_normal(n)
    fz = w + noise * rng.standard_normal(n)
    v = v_set * (1.0 + speed_noise * rng.standard_normal(n))
    tg = np.arange(0.0, n / fs_v + 0.5 * TRUTH_DT, TRUTH_DT)
    sg = _set_speed(tg, dur, lo, hi, int(steps))
    log_t = np.arange(0.0, n / fs_v, 1.0)
    params = dict(seed=int(seed), fs=fs_v, duration=dur, speeds=(lo, hi), steps=int(steps), normal_force=w,
                  noise=float(noise), speed_noise=float(speed_noise), scatter=float(scatter), mu_s=m.mu_s,
                  mu_c=m.mu_c, v_s=m.v_s, k=m.k, v_min=m.v_min, mu_min=m.mu_min, v_boundary=m.v_boundary)  # fmt: skip
    return StribeckSimulation(
        {"fy": fy, "fz": fz, "v": v}, fs_v, m, (log_t, _set_speed(log_t, dur, lo, hi, int(steps))), tg, sg,
        m.mu(sg), w, params,
    )  # fmt: skip


#: Share of the running-in transient left at ``t_steady`` (docs/method.md 6h): t_steady is the first time after
#: which |mu(t) - mu_ss| <= STEADY_DELTA |mu_0 - mu_ss|.
STEADY_DELTA: float = 0.02
RUNNING_IN_SHAPES = ("exponential", "linear")


@dataclass(frozen=True, eq=False)
class RunningInSimulation:
    """A simulated dead-weight test with running-in: :func:`running_in`.

    Attributes
    ----------
    channels : dict of str -> ndarray
        ``fy`` (friction force, N, positive) and ``fz`` (normal force, N).
    fs : float
        Sampling rate, Hz.
    t_steady : float
        The true end of the running-in (s from the start): the first time after which the transient
        ``|mu(t) - mu_ss|`` stays within :data:`STEADY_DELTA` (2 %) of its initial size ``|mu_0 - mu_ss|``;
        0 for a flat test; NaN when there is no steady state (``drift`` != 0).
    mu_0, mu_ss : float
        The COF at t = 0 and the plateau (the process mean of the COF once steady).
    shape : str
        "exponential" or "linear" (the transient's form).
    drift : float
        COF change per second added over the whole test (0: the COF settles).
    reached : bool
        True when the steady state is reached within the test (no drift and t_steady < duration).
    """

    channels: dict[str, np.ndarray]
    fs: float
    t_steady: float
    mu_0: float
    mu_ss: float
    shape: str
    drift: float
    duration: float

    @property
    def reached(self) -> bool:
        return self.drift == 0.0 and self.t_steady < self.duration

    def mu_at(self, times: Any) -> np.ndarray:
        """The deterministic COF (transient and drift, without the wander) at ``times`` (s)."""
        t = np.asarray(times, dtype=float)
        return self.mu_ss + (self.mu_0 - self.mu_ss) * _transient(t, self.t_steady, self.shape) + self.drift * t


def _transient(t: np.ndarray, t_steady: float, shape: str) -> np.ndarray:
    """The running-in transient's share g(t) (g(0) = 1, g(t_steady) = STEADY_DELTA, g -> 0)."""
    if t_steady <= 0:
        return np.asarray(np.where(t <= 0, 1.0, 0.0))
    if shape == "exponential":  # g = exp(-t / tau), tau = t_steady / ln(1 / delta)
        return np.asarray(np.exp(-np.maximum(t, 0.0) * math.log(1.0 / STEADY_DELTA) / t_steady))
    # linear: from 1 at t = 0 to 0 at t_end = t_steady / (1 - delta)
    return np.asarray(np.clip(1.0 - np.maximum(t, 0.0) * (1.0 - STEADY_DELTA) / t_steady, 0.0, 1.0))


def running_in(
    *,
    seed: int = 0,
    fs: float = 50.0,
    duration: float = 1200.0,
    mu_0: float = 0.30,
    mu_ss: float = 0.15,
    t_steady: float = 300.0,
    shape: str = "exponential",
    drift: float = 0.0,
    normal_force: float = 10.0,
    noise: float = 0.02,
    wander: float = 0.002,
    wander_time: float = 20.0,
) -> RunningInSimulation:
    """A dead-weight (classical) test whose COF runs in from ``mu_0`` to ``mu_ss`` (docs/method.md 6h).

    ``mu(t) = mu_ss + (mu_0 - mu_ss) g(t) + drift t + w(t)`` with the transient
    ``g(t) = exp(-t ln(50) / t_steady)`` ("exponential") or ``max(0, 1 - 0.98 t / t_steady)``
    ("linear", reaching mu_ss at t_steady / 0.98), so that in both t_steady is the first time after which
    ``|mu(t) - mu_ss| <= 0.02 |mu_0 - mu_ss|`` (:data:`STEADY_DELTA`); ``t_steady = 0`` is a flat test.
    ``w(t)`` is the COF's own wander, a stationary Gauss-Markov (Ornstein-Uhlenbeck) process of standard
    deviation ``wander`` and correlation time ``wander_time`` s, so the per-window COF is autocorrelated as on a
    real tribometer. The load is a dead weight: ``fz = normal_force + e_z``, ``fy = mu(t) normal_force + e_y``,
    with white Gaussian noise of ``noise`` N on both; contact from the first sample.
    """
    if shape not in RUNNING_IN_SHAPES:
        raise ValueError(f"shape must be one of {RUNNING_IN_SHAPES}, got {shape!r}")
    for name, v in (("fs", fs), ("duration", duration), ("normal_force", normal_force)):
        if not (math.isfinite(v) and v > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {v!r}")
    for name, v in (("t_steady", t_steady), ("noise", noise), ("wander", wander), ("wander_time", wander_time)):
        if not (math.isfinite(v) and v >= 0):
            raise ValueError(f"{name} must be a finite number >= 0, got {v!r}")
    rng = np.random.default_rng(seed)
    n = int(round(duration * fs))
    t = np.arange(n) / fs
    if wander > 0 and wander_time > 0:
        rho = math.exp(-1.0 / (fs * wander_time))
        e = rng.standard_normal(n) * wander * math.sqrt(1.0 - rho * rho)
        w = signal.lfilter([1.0], [1.0, -rho], e, zi=[rho * wander * rng.standard_normal()])[0]
    else:
        w = wander * rng.standard_normal(n)
    mu = mu_ss + (mu_0 - mu_ss) * _transient(t, t_steady, shape) + drift * t + w
    fz = normal_force + noise * rng.standard_normal(n)
    fy = mu * normal_force + noise * rng.standard_normal(n)
    truth = float(t_steady) if drift == 0.0 else float("nan")
    return RunningInSimulation({"fy": fy, "fz": fz}, float(fs), truth, float(mu_0), float(mu_ss), shape,
                               float(drift), float(n / fs))  # fmt: skip
