"""Shared by the benchmark scripts: the machine description and writing one
``## Section`` of benches/RESULTS.md without touching the others."""

from __future__ import annotations

import os
import platform
import re
import subprocess
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "RESULTS.md"
HEADER = "# Benchmark results\n\nMeasured on this project's machines; each section says how it was run.\n"


def machine_description() -> str:
    cpu = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(next(ln for ln in open("/proc/meminfo") if ln.startswith("MemTotal")).split()[1])
        mem = f", {kb / 2**20:.0f} GiB RAM"
    except (OSError, StopIteration, ValueError):
        pass
    try:
        rustc = subprocess.run(["rustc", "--version"], capture_output=True, text=True).stdout.strip()
    except OSError:
        rustc = "rustc unknown"
    import numpy

    return (
        f"{cpu}, {os.cpu_count()} cores{mem}; {platform.system()} {platform.release()}; "
        f"Python {platform.python_version()}, NumPy {numpy.__version__}, {rustc}"
    )


#: A section's text after this line is written by hand: a script rewriting the section keeps it.
KEEP = "<!-- written by hand below this line: the scripts that rewrite this section keep it -->"


def kept(section_text: str) -> str:
    """The hand-written end of a section (from :data:`KEEP` on), or ''."""
    at = section_text.find(KEEP)
    return "" if at < 0 else "\n" + section_text[at:].strip() + "\n"


def write_section(title: str, body: str) -> None:
    """Replaces (or appends) the section ``## title`` of RESULTS.md, keeping its hand-written end."""
    text = RESULTS.read_text() if RESULTS.exists() else HEADER
    block = f"## {title}\n\nMachine: {machine_description()}\n\n{body.strip()}\n"
    pattern = re.compile(rf"^## {re.escape(title)}\n.*?(?=^## |\Z)", re.S | re.M)
    found = pattern.search(text)
    if found:
        block += kept(found.group(0))
        text = pattern.sub(lambda _: block + "\n", text)
    else:
        text = text.rstrip("\n") + "\n\n" + block
    RESULTS.write_text(text.rstrip("\n") + "\n")


def clopper_pearson(k: int, n: int) -> str:
    """k/n with the 95 % Clopper-Pearson interval of the rate (the binomial margin; exact at 0 and n), "-" for n 0."""
    from scipy import stats

    if not n:
        return "-"
    lo = float(stats.beta.ppf(0.025, k, n - k + 1)) if k > 0 else 0.0
    hi = float(stats.beta.ppf(0.975, k + 1, n - k)) if k < n else 1.0
    return f"{k}/{n} ({lo:.2f}-{hi:.2f})"
