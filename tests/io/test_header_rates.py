"""Rates stated in text headers and time columns by name (issue 21): every file here was refused
("sampling rate unknown") before the header and time-name reading was extended."""

from __future__ import annotations

import numpy as np
import pytest
import tribodyn as td
from tribodyn.app.cli import main
from tribodyn.io import RecordingError
from tribodyn.io._text import header_rate


FS = 50.0


def _forces(n=300, seed=0):
    rng = np.random.default_rng(seed)
    fz = 10 + 0.5 * rng.standard_normal(n)
    fy = 0.2 * fz + 0.01 * rng.standard_normal(n)
    return fy, fz


def _body(sep=",", decimal="."):
    fy, fz = _forces()
    rows = "".join(f"{b:.6f}{sep}{c:.6f}\n" for b, c in zip(fy, fz))
    return rows.replace(".", decimal) if decimal != "." else rows


def _write(tmp_path, text, name="h.csv"):
    p = tmp_path / name
    p.write_bytes(text.encode("utf-8"))
    return p


@pytest.mark.fast
@pytest.mark.parametrize(
    "header,key",
    [
        # several key: value pairs on one line, separated by tabs (the rate first, in the middle, last)
        ("Sampling rate: 50\tOperator: A\tDate: 2024-05-01", "Sampling rate"),
        ("Operator: A\tSampling rate: 50 Hz\tDate: 2024-05-01", "Sampling rate"),
        ("Operator=A\tSample rate=0.05 kHz", "Sample rate"),
        ("Operator:\tA\tSampling rate:\t50", "Sampling rate"),
        ("Operator\tA\tSample rate\t50\tLoad\t10 N", "Sample rate"),
        # misspelled keys, alone and among other pairs
        ("Samplig rat: 50", "Samplig rat"),
        ("Operator: A\tSampling frequncy [Hz]: 50", "Sampling frequncy [Hz]"),
        ("Sampel-Rate = 50", "Sampel-Rate"),
        ("Abtastfrequnz: 50 Hz", "Abtastfrequnz"),
        # other languages
        ("Abtastrate: 50 Hz", "Abtastrate"),
        ("Abtastfrequenz [kHz]: 0.05", "Abtastfrequenz [kHz]"),
        ("Abtastintervall [ms]: 20", "Abtastintervall [ms]"),
        ("Messrate/Hz: 50", "Messrate/Hz"),
        ("Fréquence d'échantillonnage : 50 Hz", "Fréquence d'échantillonnage"),
        ("Période d'échantillonnage (s) = 0.02", "Période d'échantillonnage (s)"),
        ("Frecuencia de muestreo: 50", "Frecuencia de muestreo"),
        ("Frequenza di campionamento in Hz: 50", "Frequenza di campionamento in Hz"),
        ("サンプリング周波数: 50 Hz", "サンプリング周波数"),
        # any other key valued in Hz (or S/s)
        ("Erfassung [kHz]: 0.05", "Erfassung [kHz]"),
        ("Operator: A\tAcquisition card: 50 Hz", "Acquisition card"),
        ("DAQ: 50 S/s", "DAQ"),
    ],
)
def test_header_rate_is_read(tmp_path, header, key):
    p = _write(tmp_path, header + "\nFy,Fz\n" + _body())
    rec = td.open_recording(p)
    assert rec.fs == pytest.approx(FS)
    assert rec.info()["fs_source"] == f"header {key!r}"
    rec.close()


@pytest.mark.fast
def test_header_rate_with_decimal_comma_in_a_semicolon_file(tmp_path):
    p = _write(tmp_path, "Abtastfrequenz [kHz]: 0,05\tPrüfer: B\nFy;Fz\n" + _body(";", ","))
    rec = td.open_recording(p)
    assert rec.fs == pytest.approx(FS) and rec.n_samples == 300


@pytest.mark.fast
def test_a_key_known_only_by_its_hz_unit_is_named_in_a_warning(tmp_path):
    p = _write(tmp_path, "Erfassung [kHz]: 0.05\nFy,Fz\n" + _body())
    rec = td.open_recording(p)
    assert any("'Erfassung [kHz]'" in w and "fs=" in w for w in rec.warnings)
    rec = td.open_recording(p, fs=FS)  # the caller's rate: nothing to warn about
    assert not any("Erfassung" in w for w in rec.warnings)
    p = _write(tmp_path, "Abtastrate: 50 Hz\nFy,Fz\n" + _body(), "known.csv")
    assert not any("Abtastrate" in w for w in td.open_recording(p).warnings)


@pytest.mark.fast
@pytest.mark.parametrize(
    "header",
    [
        "Frequency [Hz]: 5",  # the stroke frequency of a reciprocating rig
        "Frequenz: 5 Hz",
        "Motor frequency [Hz]: 5",
        "Filter cutoff: 10 Hz",
        "Tiefpass [Hz]: 10",
        "Stroke frequency: 5 Hz\tOperator: A",
        "Oszillation [Hz]: 5",
        "Erfassung [Hz]: 50\tMessung [Hz]: 100",  # two keys valued in Hz that disagree
        "Sampling time: 600",  # a test duration, not a misspelt rate
    ],
)
def test_other_frequencies_are_not_taken_as_the_rate(tmp_path, header):
    p = _write(tmp_path, header + "\nFy,Fz\n" + _body())
    with pytest.raises(RecordingError, match="sampling rate unknown"):
        td.open_recording(p)


@pytest.mark.fast
def test_known_key_wins_over_fuzzy_and_unit_keys():
    pairs = {"Erfassung [Hz]": "10", "Samplig rate": "20", "Sampling rate": "50"}
    hit = header_rate(pairs)
    assert hit is not None and hit.hz == 50.0 and hit.key == "Sampling rate" and hit.how == "key"
    hit = header_rate({"Erfassung [Hz]": "10", "Samplig rate": "20"})
    assert hit is not None and (hit.hz, hit.how) == (20.0, "fuzzy")
    assert header_rate({"Sampling rate [s]": "0.02"}) is None  # a rate key with a time unit


@pytest.mark.fast
def test_several_pairs_on_one_line_are_split_in_the_metadata(tmp_path):
    p = _write(tmp_path, "Operator: A\tSampling rate: 50 Hz\tDate: 2024-05-01\nFy,Fz\n" + _body())
    head = td.open_recording(p).metadata["header"]
    assert head["Operator"] == "A" and head["Sampling rate"] == "50 Hz" and head["Date"] == "2024-05-01"


@pytest.mark.fast
def test_ni_channel_rows_with_tabs_are_not_split_into_pairs(tmp_path):
    fy, fz = _forces()
    t = np.arange(fy.size) / 2000.0
    head = "Channel name\tFy\t\tFz\nInterval\t0.0005\t\t0.0005\n\nTime\tValue\tTime\tValue\n"
    body = "".join(f"{a:.6f}\t{b:.6f}\t{a:.6f}\t{c:.6f}\n" for a, b, c in zip(t, fy, fz))
    rec = td.open_recording(_write(tmp_path, head + body, "ni.tsv"))
    assert rec.channel_names == ["Time", "Fy", "Fz"] and rec.fs == pytest.approx(2000.0)
    assert rec.metadata["header"]["Channel name"] == "Fy Fz"


@pytest.mark.fast
@pytest.mark.parametrize(
    "name,scale",
    [
        ("Zeit", 1.0),
        ("Zeit [s]", 1.0),
        ("Zeit/s", 1.0),
        ("Zeit in ms", 1e3),
        ("Zeit (ms)", 1e3),
        ("Time/ms", 1e3),
        ("time_ms", 1e3),
        ("Time (s)", 1.0),
        ("Temps", 1.0),
        ("Temps écoulé [s]", 1.0),
        ("Tiempo (s)", 1.0),
        ("Messzeit", 1.0),
        ("Prüfzeit [min]", 1 / 60),
        ("時間[s]", 1.0),
    ],
)
def test_time_column_names(tmp_path, name, scale):
    fy, fz = _forces()
    t = np.arange(fy.size) / FS * scale
    body = "".join(f"{a:.8f},{b:.6f},{c:.6f}\n" for a, b, c in zip(t, fy, fz))
    rec = td.open_recording(_write(tmp_path, f"{name},Fy,Fz\n" + body))
    assert rec.fs == pytest.approx(FS, rel=1e-4)  # 8 decimals of minutes
    assert rec.info()["fs_source"] == f"median step of time column {name!r}"


@pytest.mark.fast
def test_temperature_is_not_time(tmp_path):
    fy, fz = _forces()
    body = "".join(f"{20 + 0.01 * k:.4f},{b:.6f},{c:.6f}\n" for k, (b, c) in enumerate(zip(fy, fz)))
    with pytest.raises(RecordingError, match="sampling rate unknown"):
        td.open_recording(_write(tmp_path, "Temp,Fy,Fz\n" + body))


@pytest.mark.fast
def test_cli_reads_a_german_header(tmp_path, capsys):
    p = _write(tmp_path, "Prüfer: B\tAbtastrate: 50 Hz\tLast: 10 N\nFy;Fz\n" + _body(";"))
    assert main(["info", str(p)]) == 0
    out = capsys.readouterr().out
    assert "50" in out and "Abtastrate" in out
