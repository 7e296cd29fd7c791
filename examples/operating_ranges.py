"""Use case 2: the optimum temperature and current density, with 95 % intervals and a verdict.

Analyses the simulated temperature test (4060 s, the commutator heated and
cooled between 100 and 175 °C, temperature read every 100-200 s) and the
current-density test (J stepped from 2 to 6.5 A/mm²) of the paper's rig, and
fits the bathtub model of docs/method.md section 7 to COF against
temperature (heating and cooling branches apart) and against J.

Run:  python operating_ranges.py [OUT_DIR]         (default: ./operating-ranges)
Writes OUT_DIR/cof_vs_temperature.png and OUT_DIR/cof_vs_current_density.png.
"""

from __future__ import annotations

import sys
from pathlib import Path

import tribodyn as td
from tribodyn import simulate
from tribodyn.app import figures

out = Path(sys.argv[1] if len(sys.argv) > 1 else "operating-ranges")
out.mkdir(parents=True, exist_ok=True)


def show(opr: td.OperatingRange, unit: str) -> None:
    """The verdict and every branch's breakpoints with their 95 % intervals."""
    print(f"{opr.by.replace('_', ' ')}: verdict {opr.verdict!r}")
    print("  " + opr.explanation.replace("degC", "°C").replace("A/mm^2", "A/mm²"))
    for name, f in opr.fits.items():
        if f.lower is None or f.upper is None:
            print(f"  {name}: {f.verdict}")
            continue
        lci = f"[{f.lower_ci[0]:.1f}, {f.lower_ci[1]:.1f}]" if f.lower_ci else ""
        uci = f"[{f.upper_ci[0]:.1f}, {f.upper_ci[1]:.1f}]" if f.upper_ci else ""
        print(
            f"  {name}: optimum {f.lower:.1f} {lci} to {f.upper:.1f} {uci} {unit}, "
            f"minimum COF {f.mu_min:.4f} ({f.n_windows} windows)"
        )


# Temperature: the log (time in s, T in °C) is interpolated at each window.
sim_t = simulate.temperature_test(seed=1)
res_t = td.analyze(sim_t.channels, fs=sim_t.fs, window=2, hop=10, temperature=sim_t.temperature_log)
opr_t = td.operating_range(res_t, "temperature")  # method="segmented": bathtub fit with bootstrap intervals
show(opr_t, "°C")
print(f"  simulated truth: flat bottom {sim_t.truth.optimum['temperature']} °C")

# Current density: J = current / brush area, per window.
sim_j = simulate.current_density_test(seed=1)
res_j = td.analyze(sim_j.channels, fs=sim_j.fs, window=2, hop=10, area_mm2=sim_j.area_mm2)
opr_j = td.operating_range(res_j, "current_density")
show(opr_j, "A/mm²")
if opr_j.instability is not None:
    print(f"  contact loss from {opr_j.instability:.2f} A/mm²")

# The paper's Fig. 11 and Sec. 4.2 figure, as PNG files.
figures.save_figure(figures.cof_vs_temperature(res_t, opr_t), out / "cof_vs_temperature.png")
figures.save_figure(figures.cof_vs_current_density(res_j, opr_j), out / "cof_vs_current_density.png")
print(f"wrote the figures to {out}/")
