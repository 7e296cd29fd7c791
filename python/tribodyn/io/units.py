"""Unit strings found in recording files and their conversion to SI.

Only units whose meaning is unambiguous are converted automatically: force
(N, kN, mN, daN, gf, kgf, lbf, ozf), voltage (V, mV, uV, kV), current (A, mA,
uA), time (s, ms, us, min, h) and length/speed (m, mm, um, mm/s). A bare
``g`` is *not* converted here (gram-force or standard gravity?): a reader
that knows its vendor's meaning (CETR UMT writes forces in ``g`` =
gram-force) converts it itself. Unknown units are passed through unchanged
with scale 1.
"""

from __future__ import annotations

from typing import Any, Dict, List, Optional, Sequence, Tuple

__all__ = ["GRAM_FORCE", "TIME_TO_S", "check_role_units", "si_conversion"]

#: One gram-force in newtons (standard gravity 9.80665 m/s^2).
GRAM_FORCE = 9.80665e-3

_TABLE: Dict[str, Tuple[float, str]] = {
    # force
    "n": (1.0, "N"),
    "newton": (1.0, "N"),
    "newtons": (1.0, "N"),
    "kn": (1e3, "N"),
    "mn": (1e-3, "N"),
    "dan": (10.0, "N"),
    "gf": (GRAM_FORCE, "N"),
    "kgf": (9.80665, "N"),
    "kp": (9.80665, "N"),
    "lbf": (4.4482216152605, "N"),
    "ozf": (0.27801385095378125, "N"),
    # voltage
    "v": (1.0, "V"),
    "volt": (1.0, "V"),
    "volts": (1.0, "V"),
    "mv": (1e-3, "V"),
    "uv": (1e-6, "V"),
    "\u00b5v": (1e-6, "V"),
    "kv": (1e3, "V"),
    # current
    "a": (1.0, "A"),
    "amp": (1.0, "A"),
    "amps": (1.0, "A"),
    "ampere": (1.0, "A"),
    "amperes": (1.0, "A"),
    "ma": (1e-3, "A"),
    "ua": (1e-6, "A"),
    "\u00b5a": (1e-6, "A"),
    # time
    "s": (1.0, "s"),
    "sec": (1.0, "s"),
    "secs": (1.0, "s"),
    "second": (1.0, "s"),
    "seconds": (1.0, "s"),
    "ms": (1e-3, "s"),
    "us": (1e-6, "s"),
    "\u00b5s": (1e-6, "s"),
    "min": (60.0, "s"),
    "h": (3600.0, "s"),
    # length and speed
    "m": (1.0, "m"),
    "mm": (1e-3, "m"),
    "um": (1e-6, "m"),
    "\u00b5m": (1e-6, "m"),
    "m/s": (1.0, "m/s"),
    "mm/s": (1e-3, "m/s"),
    "mm/sec": (1e-3, "m/s"),
}

#: Time units -> factor to seconds (for time columns).
TIME_TO_S: Dict[str, float] = {k: f for k, (f, u) in _TABLE.items() if u == "s"}


def normalize_unit(unit: Optional[str]) -> Optional[str]:
    """Strips whitespace and one pair of surrounding brackets; empty -> None."""
    if unit is None:
        return None
    u = str(unit).strip()
    if len(u) >= 2 and (u[0], u[-1]) in (("[", "]"), ("(", ")")):
        u = u[1:-1].strip()
    return u or None


def si_conversion(unit: Optional[str]) -> Tuple[float, Optional[str], str]:
    """Factor and SI unit for a unit string found in a file.

    Parameters
    ----------
    unit : str or None
        As written in the file.

    Returns
    -------
    factor, si_unit, note
        ``value_SI = factor * value``; ``note`` describes a conversion (empty
        when the factor is 1 or the unit is unknown: then the unit is kept).
    """
    u = normalize_unit(unit)
    if u is None:
        return 1.0, None, ""
    hit = _TABLE.get(u.lower())
    if hit is None:
        return 1.0, u, ""
    f, si = hit
    if f == 1.0:
        return 1.0, si, ""
    return f, si, f"converted from {u} to {si} (x{f:g})"


def is_known_unit(token: str) -> bool:
    """True when ``token`` is a unit of the conversion table (or a common other unit)."""
    t = token.strip().lower()
    return t in _TABLE or t in {
        "g",
        "hz",
        "khz",
        "%",
        "\u00b0c",
        "degc",
        "k",
        "pa",
        "mpa",
        "kpa",
        "bar",
        "rpm",
        "nm",
        "m/s^2",
        "g/s",
    }


#: Torques (spaces, dots and middle dots removed): a friction torque over the track radius is the friction force.
TORQUE = ("nm", "nmm", "mnm", "knm")
#: Rotational speeds: a sliding speed needs the track radius (v = 2 pi r n / 60).
ROTATIONAL = ("rpm", "1/min", "r/min", "rev/min", "u/min", "min^-1", "min-1", "rps", "r/s", "rev/s", "rad/s")


def check_role_units(channels: Sequence[Any]) -> Tuple[List[str], List[str]]:
    """(errors, warnings) about the units of a recording's role channels (issue 34 point 4; docs/method.md 6f).

    ``channels`` are :class:`~tribodyn.io.base.ChannelInfo` (name, unit after conversion, role, scale, note).
    Errors: a velocity ``v`` in a rotational speed (rpm is no sliding speed); fy and fz in different units
    after conversion (the COF is their ratio). Warnings: one of fy, fz without a unit when the other has one;
    a force role in a unit that is no force (e.g. V: a ratio of two such channels is right only when both
    carry the same sensitivity); a position ``x`` without a unit (no energy or loop then).
    """
    by_role = {c.role: c for c in channels if c.role}
    errors: List[str] = []
    warnings: List[str] = []
    v = by_role.get("v")
    if v is not None and v.unit is not None and v.unit.strip().lower() in ROTATIONAL:
        errors.append(
            f"the velocity channel {v.name!r} is in {v.unit}, a rotational speed, not a sliding speed: convert it "
            "to m/s (2 pi r / 60 per rpm, r the track radius in m) with --scale v=FACTOR (scale=), or map v to a "
            "sliding speed"
        )
    fy, fz = by_role.get("fy"), by_role.get("fz")
    if fy is not None and fz is not None:
        uy, uz = (fy.unit or "").strip(), (fz.unit or "").strip()
        if uy and uz and uy.lower() != uz.lower():
            torque = uy.lower().replace(" ", "").replace("\u00b7", "").replace("*", "").replace(".", "") in TORQUE
            errors.append(
                f"fy ({fy.name!r}) is in {uy} and fz ({fz.name!r}) in {uz}: the COF is the ratio of two forces in "
                "one unit; give the conversion with --scale ROLE=FACTOR (scale=) or map the right channels"
                + ("; a friction torque: --scale fy=1/r (r the track radius in m) makes it a force" if torque else "")
            )
        elif bool(uy) != bool(uz):
            have, lack = (fy, fz) if uy else (fz, fy)
            warnings.append(
                f"{have.role} ({have.name!r}) is in {have.unit} but {lack.role} ({lack.name!r}) has no unit: the "
                f"COF takes them as the same unit"
            )
        elif uy and uy != "N" and uy.lower() == uz.lower():
            warnings.append(f"fy and fz are in {uy}, not a force: the COF is their ratio, right only when both "
                            "channels have the same sensitivity (else give --scale ROLE=FACTOR)")  # fmt: skip
    x = by_role.get("x")
    if x is not None and x.unit != "m" and "by the caller" not in (x.note or ""):
        what = f"is in {x.unit}, not a length" if x.unit else "has no unit"
        warnings.append(
            f"the position channel {x.name!r} {what}: no sliding distance, energy or friction loop is "
            "computed from it (give its factor to metres with --scale x=FACTOR, e.g. 1e-3 for mm, 1 for m)"
        )
    return errors, warnings
