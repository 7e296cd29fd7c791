"""Coverage of the headline's 95 % interval when the instrument's lag is chosen from the data (issue 35 point 3).

Each recording: the rig of ``tribodyn.simulate.conditions`` (mu = 0.1, fs = 1 kHz or ``--fs``, 250 rpm,
0.02 N white noise on fy, no fz noise of its own) with measurement noise added here to the recorded fz:
white, or white noise through a 2nd-order Butterworth band-pass (``scipy.signal.butter``; 200-450 Hz by
default, the audit's band, or 20-200 Hz, the simulator's), of std ``std(fz) 10^(-SNR/20)``, from its own
generator (seed ``(seed, 35)``). A "continuous" recording is 400 s (40 windows of 2 s at the default 10 s
hop; ``--seconds``); an "acquisitions" one is 40 separate 2 s acquisitions (``conditions(2, seed=1000 seed +
k)``), one window each.
Each is analysed with the defaults (``td.analyze(src, fs=fs)``: the lag chosen from the data) and, sharing
the simulation, with ``rpm=`` (the lag one revolution); ``--fixed L`` adds ``iv_lag=L / fs`` (a lag given);
``--rules`` picks among them.

Per cell (noise, SNR, continuous or acquisitions, lag rule): how many of the recordings' headline 95 %
intervals hold mu (k/n, with the 95 % Clopper-Pearson interval of the rate: the binomial margin) for three
intervals on the same resamples (bit for bit): "unpooled", the headline's bootstrap without the lag pooling
(``bootstrap_ci`` without ``shifts``, tribodyn before issue 35 point 3); "raw moves": pooled over the
admissible lags with the moves b(L') - b(L) over all the analysed windows as they are
(``params["iv_lag_moves"]``); and "after", ``Results.mu_r_ci``: the moves shrunk by their standard errors
over the windows (``params["iv_lag_shifts"]``, docs/method.md 3d). The mean widths of the last two over the
unpooled one; the headline's bias (mean over recordings of headline / mu - 1) and its spread between
recordings against the mean half-width / 1.96 of the unpooled interval; the lags used and pooled. At the
end, per noise kind and lag rule, the counts pooled over its cells.

Run: ``python benches/bench_lag_choice.py [--recordings 40] [--seed 5000] [--snr 6 10 20]
[--noise white band:200-450] [--layout continuous acquisitions] [--rules data rpm] [--fs 1000]
[--seconds 400] [--jobs 2] [--markdown]``.
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from concurrent.futures import ProcessPoolExecutor
from typing import Any, Dict, List, Optional, Tuple

import numpy as np

MU = 0.1
FS = 1000.0
#: "alt": the moves shrunk by this many standard errors instead of one (``--alt-z``).
ALT_Z = 2.0


def add_noise(fz: np.ndarray, snr: float, band: Optional[Tuple[float, float]], seed: int, fs: float = FS) -> np.ndarray:
    """``fz`` plus white (``band`` None) or band-limited noise of std ``std(fz) 10^(-snr/20)``."""
    from scipy import signal

    rng = np.random.default_rng([seed, 35])
    pre = 2000  # the filter's start-up, discarded
    w = rng.standard_normal(fz.size + pre)
    if band is not None:
        w = signal.sosfilt(signal.butter(2, band, btype="bandpass", fs=fs, output="sos"), w)
    w = w[pre:]
    return fz + w / w.std() * float(np.std(fz)) * 10.0 ** (-snr / 20.0)


def record(seed: int, snr: float, band: Optional[Tuple[float, float]], acquisitions: bool, fs: float = FS,
           seconds: float = 400.0) -> Any:  # fmt: skip
    """The source to analyse: a mapping (``seconds``) or a list of 40 mappings (2 s each), sampled at ``fs``."""
    from tribodyn import simulate

    def one(s: int, length: float) -> Dict[str, np.ndarray]:
        sim = simulate.conditions(length, mu=MU, seed=s, fs=fs, y_noise=0.02)
        ch = {k: np.array(v, dtype=float) for k, v in sim.channels.items()}
        ch["fz"] = add_noise(ch["fz"], snr, band, s, fs)
        return ch

    if acquisitions:
        return [one(seed * 1000 + k, 2.0) for k in range(40)]
    return one(seed, seconds)


def _interval(res: Any, shifts: Any = ()) -> Tuple[float, float]:
    """The headline's interval pooled with ``shifts`` (none: unpooled), on the same resamples as ``Results.mu_r_ci``."""
    from tribodyn.kernels.stats import bootstrap_ci, noise_resample

    mu, keep = res._gated_mu
    ci = bootstrap_ci(mu, noise=noise_resample(res.table, keep), threads=1, shifts=tuple(shifts or ()))
    lo, hi = ci.get("median", (float("nan"), float("nan")))
    gap = res.params.get("attenuation_gap")
    if res.params.get("mu_r_bound") == "lower" and gap is not None and np.isfinite(gap):
        hi += float(gap)
    return float(lo), float(hi)


Job = Tuple[int, float, Optional[Tuple[float, float]], bool, Optional[int], Tuple[str, ...], float, float, float]


def one_recording(job: Job) -> List[Dict[str, Any]]:
    """Every lag rule's row of one recording."""
    import tribodyn as td

    seed, snr, band, acq, fixed, which, fs, seconds, alt_z = job
    src = record(seed, snr, band, acq, fs, seconds)
    rules: List[Tuple[str, Dict[str, Any]]] = [("data", {}), ("rpm", {"rpm": 250.0})]
    if fixed:
        rules.append((f"iv_lag={fixed}", {"iv_lag": fixed / fs}))
    rows = []
    for rule, opts in rules:
        if rule not in which and not (rule.startswith("iv_lag") and "fixed" in which):
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = td.analyze(src, fs=fs, threads=1, **opts)
            h = res.headline
            before = _interval(res)
            raw = _interval(res, res.params.get("iv_lag_moves")) if res.params.get("iv_lag_moves") else before
            m, e = np.array(res.params.get("iv_lag_moves") or []), np.array(res.params.get("iv_lag_move_se") or [])
            alt = _interval(res, tuple(np.sign(m) * np.maximum(np.abs(m) - alt_z * e, 0.0))) if m.size else before
        rows.append(
            dict(
                seed=seed,
                rule=rule,
                value=h.value,
                after=(h.low, h.high),
                before=before,
                raw=raw,
                alt=alt,
                lag=res.params.get("iv_lag_samples"),
                shifts=len(res.params.get("iv_lag_shifts") or ()),
            )
        )
    return rows


def _cp(k: int, n: int) -> str:
    """k/n with the 95 % Clopper-Pearson interval of the rate (``_results.clopper_pearson``)."""
    from _results import clopper_pearson  # benches/ is on the path of a script run from it

    return clopper_pearson(k, n)


def _covers(iv: np.ndarray) -> int:
    return int(np.sum((iv[:, 0] <= MU) & (MU <= iv[:, 1])))


def summarise(rows: List[Dict[str, Any]]) -> Dict[str, Any]:
    """One cell's figures (module docstring)."""
    v = np.array([r["value"] for r in rows])
    b = np.array([r["before"] for r in rows])
    w = np.array([r["raw"] for r in rows])
    z = np.array([r["alt"] for r in rows])
    a = np.array([r["after"] for r in rows])
    lags = [int(r["lag"]) for r in rows]
    unpooled = np.mean(b[:, 1] - b[:, 0])
    return dict(
        n=len(rows), before=_covers(b), raw=_covers(w), after=_covers(a), alt=_covers(z),
        width_alt=float(np.mean(z[:, 1] - z[:, 0]) / unpooled),
        width_raw=float(np.mean(w[:, 1] - w[:, 0]) / unpooled), width=float(np.mean(a[:, 1] - a[:, 0]) / unpooled),
        bias=float(np.mean(v) / MU - 1), spread=float(np.std(v, ddof=1) / np.mean((b[:, 1] - b[:, 0]) / 2 / 1.96)),
        lags=f"{int(np.median(lags))} ({min(lags)}-{max(lags)})",
        pooled=f"{np.mean([r['shifts'] for r in rows]):.1f}",
    )  # fmt: skip


def main(argv: Optional[List[str]] = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--recordings", type=int, default=40)
    ap.add_argument("--seed", type=int, default=5000, help="recording r has seed SEED + r")
    ap.add_argument("--snr", type=float, nargs="+", default=[6.0, 10.0, 20.0])
    ap.add_argument("--noise", nargs="+", default=["white", "band:200-450"], help="white or band:LO-HI (Hz)")
    ap.add_argument("--layout", nargs="+", default=["continuous", "acquisitions"])
    ap.add_argument("--rules", nargs="+", default=["data", "rpm", "fixed"], help="data, rpm, fixed (with --fixed)")
    ap.add_argument("--fixed", type=int, default=0, help="also analyse with iv_lag=FIXED samples")
    ap.add_argument("--fs", type=float, default=FS, help="sampling rate, Hz")
    ap.add_argument("--alt-z", type=float, default=ALT_Z, help="the alt column: moves shrunk by ALT_Z SE")
    ap.add_argument("--seconds", type=float, default=400.0, help="length of a continuous recording, s")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--markdown", action="store_true")
    args = ap.parse_args(argv)
    out = []
    with ProcessPoolExecutor(args.jobs) as ex:
        for noise in args.noise:
            band = None if noise == "white" else tuple(float(x) for x in noise.split(":")[1].split("-"))
            for layout in args.layout:
                for snr in args.snr:
                    jobs = [(args.seed + r, snr, band, layout == "acquisitions", args.fixed or None, tuple(args.rules),
                             args.fs, args.seconds, args.alt_z) for r in range(args.recordings)]  # fmt: skip
                    rows = [x for got in ex.map(one_recording, jobs) for x in got]
                    for rule in dict.fromkeys(r["rule"] for r in rows):
                        cell = dict(noise=noise, layout=layout, snr=snr, rule=rule,
                                    **summarise([r for r in rows if r["rule"] == rule]))  # fmt: skip
                        out.append(cell)
                        print(json.dumps(cell), file=sys.stderr, flush=True)
    if args.markdown:
        print(
            "| fz noise | recordings | SNR_z | lag | lag used: median (range) | lags pooled (mean) | "
            "headline bias | spread between recordings / unpooled interval's sd | coverage unpooled | "
            f"coverage, raw moves | coverage after | coverage, moves shrunk by {args.alt_z:g} SE | "
            "width raw moves / unpooled | width after / unpooled | width shrunk by that / unpooled |"
        )
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for c in out:
            print(
                f"| {c['noise']} | {c['layout']} | {c['snr']:g} dB | {c['rule']} | {c['lags']} | {c['pooled']} | "
                f"{100 * c['bias']:+.2f} % | {c['spread']:.2f} | {_cp(c['before'], c['n'])} | "
                f"{_cp(c['raw'], c['n'])} | {_cp(c['after'], c['n'])} | {_cp(c['alt'], c['n'])} | "
                f"{c['width_raw']:.2f} | {c['width']:.2f} | {c['width_alt']:.2f} |"
            )
        print()
        print(f"| fz noise | lag | recordings | coverage unpooled | coverage, raw moves | coverage after | "
              f"coverage, moves shrunk by {args.alt_z:g} SE |")  # fmt: skip
        print("|---|---|---|---|---|---|---|")
        for noise in args.noise:
            for rule in dict.fromkeys(c["rule"] for c in out):
                cs = [c for c in out if c["noise"] == noise and c["rule"] == rule]
                n = sum(c["n"] for c in cs)
                if n:
                    k = [sum(c[x] for c in cs) for x in ("before", "raw", "after", "alt")]
                    print(f"| {noise} | {rule} | {n} | " + " | ".join(_cp(x, n) for x in k) + " |")


if __name__ == "__main__":
    main()
