"""The report's figures as a declared registry (issue 33 point 3; app/figure_registry.py).

``build_named_figures`` walks the registry. The names, order and captions it gives are those of the
function it replaced (one long ``report.build_named_figures``, git 98966e4), recorded here as literals on
several Results: a dynamic headline with temperature, with current density (two example windows), the
classical headline of a speed sweep and of a real export, reciprocating tests with strokes, cycles and
friction loops (per-stroke and dynamic headline), a plain dynamic test; and the variants without
``cof_vs_time``, loops or examples. The figures are not drawn here: each entry's drawing is replaced by
a stub that records which function of ``app/figures.py`` it calls (the PNGs were compared byte for byte
when the registry came in, and ``tests/app/test_figures_report.py`` draws them).
"""

from __future__ import annotations

from typing import Any, Dict, List, Tuple

import pytest
import tribodyn as td
from tribodyn import simulate
from tribodyn.app import figure_registry as FR
from tribodyn.app import figures, jobs, report

REAL = "tests/data/real/pod_PPS_100N_1.tsv"

#: The function of app/figures.py that draws each figure (by its name without the example window's tag).
DRAWN_BY = {
    "fig02_forces": "forces_vs_time",
    "fig03-05_correlations": "correlation_functions",
    "fig06-08_phase_plots": "phase_plots",
    "fig09_cof_vs_normal_force": "cof_vs_normal_force",
    "fig10_cof_temperature_vs_time": "cof_and_temperature_vs_time",
    "fig11_cof_vs_temperature": "cof_vs_temperature",
    "fig12_cof_current_density_vs_time": "cof_and_current_density_vs_time",
    "sec4-2_cof_vs_current_density": "cof_vs_current_density",
    "stribeck_curve": "stribeck_curve",
    "cof_vs_time": "cof_vs_time",
    "strokes_cof_vs_cycle": "strokes_vs_cycle",
    "friction_loops": "friction_loops",
    "energy_vs_cycle": "energy_vs_cycle",
}

#: The captions of a reciprocating test's stroke, loop and energy figures (the same in both reciprocating cases).
_STROKE_FIGURES = [
    (
        "strokes_cof_vs_cycle",
        (
            "Reciprocating test: per-stroke classical COF (mean |fy|/|fz| over the central 0.5 of each "
            "stroke) against cycle number, one marker per sliding direction (41 strokes); "
            "docs/method.md 6c."
        ),
    ),
    (
        "friction_loops",
        (
            "Friction loops: the friction force against the position over the first, a middle and the "
            "last whole cycle; the area inside a loop is the energy friction dissipates in that cycle "
            "(docs/method.md 6c)."
        ),
    ),
    (
        "energy_vs_cycle",
        (
            "Energy dissipated per cycle (the friction loop's area, sum of F_y dx) and the energy COF, "
            "energy / (mean F_n x sliding distance), against cycle number (docs/method.md 6c)."
        ),
    ),
]


#: Recorded from the code before the registry (git 98966e4): case -> [(file name, caption)], in order.
EXPECTED: Dict[str, List[Tuple[str, str]]] = {
    "temperature": [
        (
            "fig02_forces_representative",
            (
                "Dynamic forces of the representative gated window (no. 0, t = 0 s, COF closest to the "
                "median) (2 s at 1000 Hz from t = 0 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_representative",
            (
                "Correlation functions C_xy, C_xz, C_yz of the representative gated window (no. 0, t = 0 "
                "s, COF closest to the median) against the time shift, Eq. (1); C_yz(0) = -0.981, quality "
                "gate passed; cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_representative",
            (
                "Force phase plots of the representative gated window (no. 0, t = 0 s, COF closest to the "
                "median) with the regression of F_y,d on F_z,d (mu_r = 0.1004, orientation s = -1); cf. "
                "paper Figs. 6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_representative",
            (
                "COF per F_z,d bin of the representative gated window (no. 0, t = 0 s, COF closest to the "
                "median), deadband 0.35 N shaded; mu_r = 0.1004, mu_a = 0.1003, mu_b = 0.1004; cf. paper "
                "Fig. 9."
            ),
        ),
        (
            "fig10_cof_temperature_vs_time",
            (
                "COF (mu_r by regression, mu_a and mu_b per normal-force sign) and commutator temperature "
                "against time (406 windows, 406 passed the quality gate; line and shaded band: running "
                "median and 5-95 % of the gated windows; failed windows as grey ticks in the strip at the "
                "top, with their commonest reasons); cf. paper Fig. 10."
            ),
        ),
        (
            "fig11_cof_vs_temperature",
            (
                "COF against temperature, heating and cooling branches apart (hysteresis) with binned "
                "medians. Bathtub fit (line) with its 95 % bootstrap band; verdict: optimum. The COF is "
                "lowest (0.1002) between 134.6 and 157.6 °C and rises on both sides (flat fit rejected, p "
                "= 1.8e-249). all (400 windows, optimum): lower breakpoint 134.6 [99.91, 143.2] °C, upper "
                "breakpoint 157.6 [147.8, 162.5] °C, minimum COF 0.1002 [0.09961, 0.1008], COF 1.5 × the "
                "minimum at 171.9 [168.6, inf] °C. heating (238 windows, optimum): lower breakpoint 135 "
                "[133, 156] °C, upper breakpoint 159.6 [158.6, 162.3] °C, minimum COF 0.1 [0.09989, "
                "0.1001], COF 1.5 × the minimum at 173.4 [173.2, 173.6] °C. cooling (271 windows, "
                "optimum): lower breakpoint 136.1 [99.91, 146.5] °C, upper breakpoint 155.1 [153.9, 156.3] "
                "°C, minimum COF 0.09994 [0.09986, 0.1001], COF 1.5 × the minimum at 168.6 [168.1, 168.9] "
                "°C. Hysteresis of the upper edge (heating − cooling): 4.406 [3.303, 7.472] °C. Left out "
                "of the fit: 6 (temperature log gap). Cf. paper Fig. 11."
            ),
        ),
    ],
    "current": [
        (
            "fig02_forces_representative",
            (
                "Dynamic forces of the representative gated window (no. 23, t = 230 s, COF closest to the "
                "median) (2 s at 1000 Hz from t = 230 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_representative",
            (
                "Correlation functions C_xy, C_xz, C_yz of the representative gated window (no. 23, t = "
                "230 s, COF closest to the median) against the time shift, Eq. (1); C_yz(0) = -0.9923, "
                "quality gate passed; cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_representative",
            (
                "Force phase plots of the representative gated window (no. 23, t = 230 s, COF closest to "
                "the median) with the regression of F_y,d on F_z,d (mu_r = 0.14, orientation s = -1); cf. "
                "paper Figs. 6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_representative",
            (
                "COF per F_z,d bin of the representative gated window (no. 23, t = 230 s, COF closest to "
                "the median), deadband 0.35 N shaded; mu_r = 0.14, mu_a = 0.1398, mu_b = 0.1405; cf. paper "
                "Fig. 9."
            ),
        ),
        (
            "fig02_forces_worst",
            (
                "Dynamic forces of the worst failing window (no. 66, t = 660 s, smallest |C_yz(0)|; "
                "failed: imprecise: expected 95 % interval +-17.2 % of the recording's COF > +-10 %; "
                "contact loss: |C_yz(0)| = 0.353 at a current in the upper half of the range) (2 s at 1000 "
                "Hz from t = 660 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_worst",
            (
                "Correlation functions C_xy, C_xz, C_yz of the worst failing window (no. 66, t = 660 s, "
                "smallest |C_yz(0)|; failed: imprecise: expected 95 % interval +-17.2 % of the recording's "
                "COF > +-10 %; contact loss: |C_yz(0)| = 0.353 at a current in the upper half of the "
                "range) against the time shift, Eq. (1); C_yz(0) = -0.353, quality gate failed (imprecise: "
                "expected 95 % interval +-17.2 % of the recording's COF > +-10 %; contact loss: |C_yz(0)| "
                "= 0.353 at a current in the upper half of the range); cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_worst",
            (
                "Force phase plots of the worst failing window (no. 66, t = 660 s, smallest |C_yz(0)|; "
                "failed: imprecise: expected 95 % interval +-17.2 % of the recording's COF > +-10 %; "
                "contact loss: |C_yz(0)| = 0.353 at a current in the upper half of the range) with the "
                "regression of F_y,d on F_z,d (mu_r = 0.2019, orientation s = -1); cf. paper Figs. 6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_worst",
            (
                "COF per F_z,d bin of the worst failing window (no. 66, t = 660 s, smallest |C_yz(0)|; "
                "failed: imprecise: expected 95 % interval +-17.2 % of the recording's COF > +-10 %; "
                "contact loss: |C_yz(0)| = 0.353 at a current in the upper half of the range), deadband "
                "0.35 N shaded; mu_r = 0.2019, mu_a = 0.2424, mu_b = 0.2482; cf. paper Fig. 9."
            ),
        ),
        (
            "fig12_cof_current_density_vs_time",
            (
                "COF and current density J against time (70 windows, 64 passed the quality gate; failed "
                "windows as grey ticks in the strip at the top, with their commonest reasons); cf. paper "
                "Fig. 12."
            ),
        ),
        (
            "sec4-2_cof_vs_current_density",
            (
                "COF against current density with binned medians. Bathtub fit (line) with its 95 % "
                "bootstrap band; verdict: optimum. The COF is lowest (0.1024) between 4.298 and 5.235 "
                "A/mm² and rises on both sides (flat fit rejected, p = 2e-30). all (64 windows, optimum): "
                "lower breakpoint 4.298 [4, 5] A/mm², upper breakpoint 5.235 [4.5, 5.5] A/mm², minimum COF "
                "0.1024 [0.1002, 0.104], COF 1.5 × the minimum at 5.615 [5.407, inf] A/mm². Contact loss "
                "from 6.5 A/mm² (onset between [5.975, 6.525]). Left out of the fit: 6 (contact loss). Cf. "
                "paper Sec. 4.2."
            ),
        ),
    ],
    "speed": [
        (
            "stribeck_curve",
            (
                "Stribeck curve: COF of each window against its mean sliding speed (log axis), the bathtub "
                "fit on log speed and the regimes its walls stand for (docs/method.md 7a). Bathtub fit "
                "(line) with its 95 % bootstrap band; verdict: optimum. The COF is lowest (0.0624) between "
                "0.02747 and 0.08157 m/s and rises on both sides (flat fit rejected, p = 7.4e-78). all "
                "(120 windows, optimum): lower breakpoint 0.02747 [0.01372, 0.03447] m/s, upper breakpoint "
                "0.08157 [0.0387, 0.2175] m/s, minimum COF 0.06238 [0.06103, 0.06415], COF 1.5 × the "
                "minimum at 0.6466 [0.6026, inf] m/s."
            ),
        ),
        (
            "cof_vs_time",
            (
                "COF against time (120 windows: the classical COF of each and the instrument's where the "
                "file has it; black line and grey band: the headline (classical COF, mean) and its 95 % "
                "interval); no temperature or current density was given."
            ),
        ),
    ],
    "export": [
        (
            "cof_vs_time",
            (
                "COF against time (18 windows: the classical COF of each and the instrument's where the "
                "file has it; black line and grey band: the headline (classical COF, mean) and its 95 % "
                "interval); no temperature or current density was given."
            ),
        ),
        (
            "fig02_forces_worst",
            (
                "Dynamic forces of the worst failing window (no. 0, t = 0 s, smallest |C_yz(0)|; failed: "
                "degenerate: fewer than 3 samples, constant fz or no fz variance beyond its noise) (100 s "
                "at 1 Hz from t = 0 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_worst",
            (
                "Correlation functions C_xy, C_xz, C_yz of the worst failing window (no. 0, t = 0 s, "
                "smallest |C_yz(0)|; failed: degenerate: fewer than 3 samples, constant fz or no fz "
                "variance beyond its noise) against the time shift, Eq. (1); C_yz(0) = NaN, quality gate "
                "failed (degenerate: fewer than 3 samples, constant fz or no fz variance beyond its "
                "noise); cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_worst",
            (
                "Force phase plots of the worst failing window (no. 0, t = 0 s, smallest |C_yz(0)|; "
                "failed: degenerate: fewer than 3 samples, constant fz or no fz variance beyond its noise) "
                "with the regression of F_y,d on F_z,d (mu_r = NaN, orientation s = +1); cf. paper Figs. "
                "6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_worst",
            (
                "COF per F_z,d bin of the worst failing window (no. 0, t = 0 s, smallest |C_yz(0)|; "
                "failed: degenerate: fewer than 3 samples, constant fz or no fz variance beyond its "
                "noise), deadband 0.35 N shaded; mu_r = NaN, mu_a = NaN, mu_b = 0.1455; cf. paper Fig. 9."
            ),
        ),
    ],
    "recip": [
        (
            "stribeck_curve",
            (
                "Stribeck curve: COF of each window against its mean sliding speed (log axis), the bathtub "
                "fit on log speed and the regimes its walls stand for (docs/method.md 7a). Bathtub fit "
                "(line) with its 95 % bootstrap band; verdict: no dependence. A constant COF of 0.1107 "
                "fits as well as a bathtub (F-test p = 0.39 >= 0.01): the COF does not depend on the speed "
                "over 0.04301-0.05657 m/s. all (41 windows, no dependence): minimum COF 0.1107 [0.1092, "
                "0.1107]."
            ),
        ),
        (
            "cof_vs_time",
            (
                "COF against time (41 windows: the classical COF of each and the instrument's where the "
                "file has it; black line and grey band: the headline (per-stroke COF, mean) and its 95 % "
                "interval); no temperature or current density was given."
            ),
        ),
        *_STROKE_FIGURES,
        (
            "fig02_forces_worst",
            (
                "Dynamic forces of the worst failing window (no. 18, t = 4.438 s, smallest |C_yz(0)|; "
                "failed: imprecise: expected 95 % interval +-1585.6 % of the recording's COF > +-10 %) "
                "(0.126 s at 1000 Hz from t = 4.438 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_worst",
            (
                "Correlation functions C_xy, C_xz, C_yz of the worst failing window (no. 18, t = 4.438 s, "
                "smallest |C_yz(0)|; failed: imprecise: expected 95 % interval +-1585.6 % of the "
                "recording's COF > +-10 %) against the time shift, Eq. (1); C_yz(0) = -0.003805, quality "
                "gate failed (imprecise: expected 95 % interval +-1585.6 % of the recording's COF > +-10 "
                "%); cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_worst",
            (
                "Force phase plots of the worst failing window (no. 18, t = 4.438 s, smallest |C_yz(0)|; "
                "failed: imprecise: expected 95 % interval +-1585.6 % of the recording's COF > +-10 %) "
                "with the regression of F_y,d on F_z,d (mu_r = 0.00375, orientation s = -1); cf. paper "
                "Figs. 6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_worst",
            (
                "COF per F_z,d bin of the worst failing window (no. 18, t = 4.438 s, smallest |C_yz(0)|; "
                "failed: imprecise: expected 95 % interval +-1585.6 % of the recording's COF > +-10 %), "
                "deadband 0.35 N shaded; mu_r = 0.00375, mu_a = NaN, mu_b = -0.1402; cf. paper Fig. 9."
            ),
        ),
    ],
    "recip_dynamic": [
        (
            "fig02_forces_representative",
            (
                "Dynamic forces of the representative gated window (no. 9, t = 2.188 s, COF closest to the "
                "median) (0.125 s at 1000 Hz from t = 2.188 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_representative",
            (
                "Correlation functions C_xy, C_xz, C_yz of the representative gated window (no. 9, t = "
                "2.188 s, COF closest to the median) against the time shift, Eq. (1); C_yz(0) = -0.9696, "
                "quality gate passed; cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_representative",
            (
                "Force phase plots of the representative gated window (no. 9, t = 2.188 s, COF closest to "
                "the median) with the regression of F_y,d on F_z,d (mu_r = -0.1098, orientation s = +1); "
                "cf. paper Figs. 6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_representative",
            (
                "COF per F_z,d bin of the representative gated window (no. 9, t = 2.188 s, COF closest to "
                "the median), deadband 0.35 N shaded; mu_r = -0.1098, mu_a = NaN, mu_b = -0.1096; cf. "
                "paper Fig. 9."
            ),
        ),
        (
            "stribeck_curve",
            (
                "Stribeck curve: COF of each window against its mean sliding speed (log axis), the bathtub "
                "fit on log speed and the regimes its walls stand for (docs/method.md 7a). Bathtub fit "
                "(line) with its 95 % bootstrap band; verdict: no dependence. A constant COF of 0.1097 "
                "fits as well as a bathtub (F-test p = 0.25 >= 0.01): the COF does not depend on the speed "
                "over 0.04301-0.05657 m/s. all (41 windows, no dependence): minimum COF 0.1097 [0.1089, "
                "0.1104]."
            ),
        ),
        (
            "cof_vs_time",
            (
                "COF against time (41 windows, 41 passed the quality gate; failed windows as grey ticks in "
                "the strip at the top, with their commonest reasons); no temperature or current density "
                "was given."
            ),
        ),
        *_STROKE_FIGURES,
    ],
    "plain": [
        (
            "fig02_forces_representative",
            (
                "Dynamic forces of the representative gated window (no. 330, t = 3300 s, COF closest to "
                "the median) (2 s at 1000 Hz from t = 3300 s); cf. paper Fig. 2."
            ),
        ),
        (
            "fig03-05_correlations_representative",
            (
                "Correlation functions C_xy, C_xz, C_yz of the representative gated window (no. 330, t = "
                "3300 s, COF closest to the median) against the time shift, Eq. (1); C_yz(0) = -0.9855, "
                "quality gate passed; cf. paper Figs. 3-5."
            ),
        ),
        (
            "fig06-08_phase_plots_representative",
            (
                "Force phase plots of the representative gated window (no. 330, t = 3300 s, COF closest to "
                "the median) with the regression of F_y,d on F_z,d (mu_r = 0.1004, orientation s = -1); "
                "cf. paper Figs. 6-8."
            ),
        ),
        (
            "fig09_cof_vs_normal_force_representative",
            (
                "COF per F_z,d bin of the representative gated window (no. 330, t = 3300 s, COF closest to "
                "the median), deadband 0.35 N shaded; mu_r = 0.1004, mu_a = 0.101, mu_b = 0.1008; cf. "
                "paper Fig. 9."
            ),
        ),
        (
            "cof_vs_time",
            (
                "COF against time (406 windows, 406 passed the quality gate; line and shaded band: running "
                "median and 5-95 % of the gated windows; failed windows as grey ticks in the strip at the "
                "top, with their commonest reasons); no temperature or current density was given."
            ),
        ),
    ],
}

#: Variants: (base case, its names in order: the base's captions, fewer figures).
VARIANTS: Dict[str, Tuple[str, List[str]]] = {
    "temperature_notime": ("temperature", [n for n, _ in EXPECTED["temperature"]]),
    "speed_auto": ("speed", ["stribeck_curve"]),
    "export_notime": ("export", [n for n, _ in EXPECTED["export"]][1:]),
    "recip_noloops": ("recip", ["stribeck_curve", "cof_vs_time", "strokes_cof_vs_cycle", "energy_vs_cycle"]),
}


class _Drawn:
    """Stands in for app/figures.py: each drawing returns which function drew it; constants stay."""

    def __getattr__(self, name: str) -> Any:
        real = getattr(figures, name)
        return (lambda *a, **k: f"drawn by {name}") if callable(real) else real


@pytest.fixture
def stub_drawing(monkeypatch):
    monkeypatch.setattr(FR, "_figs", _Drawn)


@pytest.fixture(scope="module")
def cases(temp_sim, temp_res, cd_sim, cd_res) -> Dict[str, Tuple[Any, Dict[str, Any]]]:
    """case -> (Results, build_named_figures' keyword arguments)."""
    ex = jobs.diagnostic_examples(temp_sim.channels, temp_res)
    out = {
        "temperature": (temp_res, dict(examples=ex, temperature_log=temp_sim.temperature_log)),
        "temperature_notime": (temp_res, dict(examples=ex[:1], time_figure=False)),
        "current": (cd_res, dict(examples=jobs.diagnostic_examples(cd_sim.channels, cd_res))),
    }
    s = simulate.stribeck_sweep(seed=3)
    r = td.analyze(s.channels, fs=s.fs, window=5.0, hop=5.0)
    out["speed"] = (r, dict(opr_speed=td.operating_range(r, by="speed")))
    out["speed_auto"] = (r, dict(time_figure=False))
    r = td.analyze(REAL)
    with td.open_recording(REAL) as rec:
        ex = jobs.diagnostic_examples(rec, r)
    out["export"] = (r, dict(examples=ex))
    out["export_notime"] = (r, dict(examples=ex, time_figure=False))
    rc = simulate.reciprocating(seed=4, offset=0.2)
    r = td.analyze(rc.channels, fs=rc.fs)
    loops = jobs.loop_examples(rc.channels, r)
    out["recip"] = (r, dict(loops=loops, examples=jobs.diagnostic_examples(rc.channels, r)))
    out["recip_noloops"] = (r, {})
    rc = simulate.reciprocating(seed=3, mu_forward=0.11, mu_backward=0.11, fz_dynamic=1.0)
    r = td.analyze(rc.channels, fs=rc.fs)
    out["recip_dynamic"] = (r, dict(loops=jobs.loop_examples(rc.channels, r),
                                    examples=jobs.diagnostic_examples(rc.channels, r)))  # fmt: skip
    plain = simulate.temperature_test(seed=5)
    r = td.analyze(plain.channels, fs=plain.fs, window=2.0, hop=10.0)
    out["plain"] = (r, dict(examples=jobs.diagnostic_examples(plain.channels, r)))
    return out


def _expected(case: str) -> List[Tuple[str, str]]:
    if case in EXPECTED:
        return EXPECTED[case]
    base, names = VARIANTS[case]
    captions = dict(EXPECTED[base])
    return [(n, captions[n]) for n in names]


@pytest.mark.parametrize("case", [*EXPECTED, *VARIANTS])
def test_the_registry_gives_the_figures_of_the_code_it_replaced(case, cases, stub_drawing):
    res, kw = cases[case]
    got = report.build_named_figures(res, **kw)
    assert [(n, c) for n, c, _ in got] == _expected(case)
    for name, _, drawn in got:
        stem = next(s for s in DRAWN_BY if name == s or name.startswith(s + "_"))
        assert drawn == f"drawn by {DRAWN_BY[stem]}", name


def test_the_headline_places_the_window_diagnostics(cases):
    heads = {case: cases[case][0].headline.method for case in EXPECTED}
    assert heads == {"temperature": "dynamic", "current": "dynamic", "speed": "classical", "export": "classical",
                     "recip": "per-stroke", "recip_dynamic": "dynamic", "plain": "dynamic"}  # fmt: skip
    for case, figs in EXPECTED.items():
        diag = [k for k, (n, _) in enumerate(figs) if n.startswith("fig0")]
        if diag:  # a block, first for a dynamic headline, last otherwise
            assert diag == list(range(diag[0], diag[0] + len(diag)))
            assert (diag[0] == 0) == (heads[case] == "dynamic") and (diag[-1] == len(figs) - 1 or diag[0] == 0)


def test_one_entry_per_figure_and_every_figure_drawn_by_its_function():
    names = [e.name for e in FR.RECORDING_FIGURES] + [w.stem for w in FR.WINDOW_FIGURES]
    assert sorted(names) == sorted(DRAWN_BY) and len(set(names)) == len(names)


def test_a_new_figure_is_one_entry(cases, monkeypatch, stub_drawing):
    """A figure added by one entry of RECORDING_FIGURES comes out in its place, with its caption, when it applies."""
    entry = FR.FigureEntry("mu_r_histogram", lambda d: d.has("mu_r"), lambda d: "Histogram of mu_r.",
                           lambda d: "drawn by histogram")  # fmt: skip
    monkeypatch.setattr(FR, "RECORDING_FIGURES", (*FR.RECORDING_FIGURES, entry))
    res, kw = cases["plain"]
    got = [(n, c, f) for n, c, f in report.build_named_figures(res, **kw)]
    assert got[-1] == ("mu_r_histogram", "Histogram of mu_r.", "drawn by histogram")
    assert [(n, c) for n, c, _ in got[:-1]] == EXPECTED["plain"]
