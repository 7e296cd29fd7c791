"""Tests of tribodyn.io: the recording readers on real instrument files
(tests/data/real, provenance in tests/data/README.md), the writers' round
trips, chunked reading, and the errors users meet.

Row counts and sample values below were checked by hand against the files'
text (line numbers given where useful).
"""

from __future__ import annotations

import hashlib
import json
import os
import tracemalloc
from pathlib import Path

import h5py
import numpy as np
import pytest
import tribodyn.io
from tribodyn.io import ChannelInfo, Recording, RecordingError, open_recording
from tribodyn.io.writers import atomic_write, save_hdf5, save_npy, save_npz, save_tdms, sha256_file
from _paths import TESTS


REAL = TESTS / "data" / "real"
G0 = 9.80665e-3  # gram-force in N

CETR1 = REAL / "cetr_umt2_HT-2n-6-4_2_001.csv"
CETR2 = REAL / "cetr_umt2_HT-2n-6-4_2_002.csv"
POD60 = REAL / "pod_PPS_60N_1.tsv"
POD100 = REAL / "pod_PPS_100N_1.tsv"
LVM_LONG = REAL / "lvm_read_long_single_header_multi_ch.lvm"
LVM_SHORT = REAL / "lvm_read_short.lvm"
TDMS = REAL / "nptdms_raw1_daqmx.tdms"
NPY = REAL / "pyfrf_measurements_1.npy"

CETR_COLUMNS = ["Fx", "Fz", "Z", "Y", "X", "V1", "V2", "V3", "T", "Ff", "COF"]
POD_COLUMNS = [
    "This Step", "Step Time", "Test Time", "Sliding Velocity", "Speed", "Mass", "Load",
    "TOTAL REVOLUTIONS", "Specimen Temp", "Contact Potential", "Radius", "Distance",
    "Friction Force", "Friction Coefficient", "Displacement", "Friction Force.1",
]  # fmt: skip
TDMS_COLUMNS = [
    "First  Channel", "Second Chan", "Third Chan", "Fourth Chan", "Fifth Chan",
    "Sixth Chan", "Seventh Cha",
]  # fmt: skip

# (file, open kwargs) of every real file, for the generic checks
ALL_REAL = [
    (CETR1, {}),
    (CETR2, {}),
    (POD60, {}),
    (POD100, {}),
    (LVM_LONG, {}),
    (LVM_SHORT, {}),
    (TDMS, {}),
    (NPY, {"fs": 25600.0}),
]


def _chunked(rec: Recording, size: int, roles=None) -> dict:
    parts = list(rec.chunks(size, roles))
    lengths = [len(next(iter(p.values()))) for p in parts]
    assert all(n == size for n in lengths[:-1])
    assert 0 < lengths[-1] <= size
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


# --------------------------------------------------------------------- all files
@pytest.mark.fast
def test_package_exports():
    assert tribodyn.io.open_recording is open_recording
    assert issubclass(RecordingError, ValueError)
    for name in ("save_npz", "save_hdf5", "save_tdms", "atomic_write", "sha256_file"):
        assert hasattr(tribodyn.io, name)


@pytest.mark.fast
def test_test_data_is_byte_exact_copy():
    # CRLF line ends must survive (the counts and offsets below rely on them)
    assert CETR1.read_bytes().count(b"\r\n") == 257
    assert POD60.read_bytes().count(b"\r\n") == 1818
    assert TDMS.stat().st_size == 34568


@pytest.mark.fast
@pytest.mark.parametrize("path, kw", ALL_REAL, ids=lambda v: getattr(v, "name", ""))
@pytest.mark.parametrize("size", [1, 7, 1000, "n+1"])
def test_chunks_concatenate_to_read(path, kw, size):
    with open_recording(path, **kw) as rec:
        names = rec.channel_names
        full = rec.read(names)
        n = rec.n_samples
        got = _chunked(rec, n + 1 if size == "n+1" else size, names)
        assert set(got) == set(names)
        for k in names:
            assert full[k].dtype == np.float64 and full[k].shape == (n,)
            np.testing.assert_array_equal(got[k], full[k])
        # default roles: the mapped roles, or all channels when none is mapped
        default = rec.read()
        assert set(default) == (set(rec.roles) if rec.roles else set(names))


@pytest.mark.fast
@pytest.mark.parametrize("path, kw", ALL_REAL, ids=lambda v: getattr(v, "name", ""))
def test_info_and_recording_basics(path, kw):
    with open_recording(path, **kw) as rec:
        info = rec.info()
        assert info["size_bytes"] == path.stat().st_size
        assert info["n_samples"] == rec.n_samples > 0
        assert info["duration"] == pytest.approx(rec.n_samples / rec.fs)
        assert [c["name"] for c in info["channels"]] == rec.channel_names
        assert all(isinstance(c, ChannelInfo) for c in rec.channels)
        assert rec.segments[0][0] == 0 and rec.segments[-1][1] == rec.n_samples
        assert "Recording" in repr(rec)
        json.dumps(info)  # for `tribodyn info --json`
    assert rec.closed
    with pytest.raises(RecordingError, match="closed"):
        rec.read()


# --------------------------------------------------------------------------- CETR
@pytest.mark.fast
@pytest.mark.parametrize(
    "path, blocks, first, last",
    [
        # first data row (line 24) and last data row of each file: Fx, Fz, T, Ff, COF
        (CETR1, [(0, 110), (110, 217)],
         (7.683862, -198.963455, 0.0, 7.683862, 0.038619),
         (166.937256, -200.074905, 2.1177, 166.937256, 0.834374)),
        (CETR2, [(0, 108), (108, 216)],
         (166.661591, -200.222214, 0.0, 166.661591, 0.832383),
         (159.247330, -200.076569, 2.1322, 159.247330, 0.795932)),
    ],
)  # fmt: skip
def test_cetr(path, blocks, first, last):
    with open_recording(path) as rec:
        assert rec.format == "cetr"
        assert rec.channel_names == CETR_COLUMNS
        assert rec.n_samples == blocks[-1][1]
        assert rec.segments == blocks  # one segment per "Step" block (Data Count lines agree)
        assert rec.fs == 50.0  # median step of T (0.02 s)
        assert rec.roles == {"fy": "Ff", "fz": "Fz", "cof": "COF"}
        info = {c.name: c for c in rec.channels}
        for name in ("Fx", "Fz", "Ff"):
            c = info[name]
            assert (c.raw_unit, c.unit, c.scale) == ("g", "N", G0)
            assert "gram-force" in c.note
        assert info["T"].unit == "s" and info["COF"].unit is None
        assert info["Fz"].role == "fz" and info["Fx"].role is None
        d = rec.read(["Fx", "fz", "T", "fy", "cof"])
        for k, v0, v1 in zip(["Fx", "fz", "T", "fy", "cof"], first, last):
            f = G0 if k in ("Fx", "fz", "fy") else 1.0
            assert d[k][0] == pytest.approx(v0 * f, rel=1e-12, abs=0)
            assert d[k][-1] == pytest.approx(v1 * f, rel=1e-12, abs=0)
        # T restarts at 0 in the second step
        assert d["T"][blocks[1][0]] == 0.0


@pytest.mark.fast
@pytest.mark.parametrize("path", [CETR1, CETR2])
def test_cetr_cof_column_consistency(path):
    """Ff = |Fx| exactly and COF = Ff/|Fz| to the file's 6 digits (Fz < 0: compression)."""
    with open_recording(path) as rec:
        d = rec.read(["fy", "fz", "cof", "Fx"])
    np.testing.assert_array_equal(d["fy"], np.abs(d["Fx"]))
    assert np.all(d["fz"] < -1.9)  # about -200 gf everywhere
    ratio = d["fy"] / np.abs(d["fz"])
    big = np.abs(d["fz"]) > 0.5
    assert big.all()
    rel = np.abs(ratio[big] - d["cof"][big]) / np.abs(d["cof"][big])
    assert rel.max() < 0.02  # the lead's criterion
    assert rel.max() < 1e-4  # what the files actually give (max 2.3e-5)
    # the signed Fx/Fz does not reproduce COF (sign flips with the stroke)
    assert np.max(np.abs(np.abs(d["Fx"] / d["fz"]) - d["cof"])) < 1e-5
    assert np.any(np.sign(d["Fx"]) != np.sign(d["Fx"][0]))


@pytest.mark.fast
def test_cetr_channels_and_scale_override():
    with open_recording(CETR1, channels={"fy": "Fx", "cof": None}, scale={"fz": 1.0}) as rec:
        assert rec.roles == {"fy": "Fx", "fz": "Fz"}
        d = rec.read()
        assert d["fz"][0] == -198.963455  # raw grams: the user's scale replaced the automatic one
        assert d["fy"][0] == pytest.approx(7.683862 * G0)
        fz = {c.name: c for c in rec.channels}["Fz"]
        assert fz.scale == 1.0 and fz.unit is None
    with pytest.raises(RecordingError, match="'fx'.*not a mapped role|neither a mapped role"):
        open_recording(CETR1, scale={"fx": 2.0})  # fx is not mapped: no fall back to 'Fx'
    with open_recording(CETR1, scale={"Fx": 2.0}, units={"Fx": "2 gf"}) as rec:
        fx = {c.name: c for c in rec.channels}["Fx"]
        assert (fx.scale, fx.unit) == (2.0, "2 gf")
        assert rec.read(["Fx"])["Fx"][0] == 2 * 7.683862


@pytest.mark.fast
def test_cetr_truncated_at_line_boundary(tmp_path):
    data = CETR1.read_bytes()
    cut = tmp_path / "cut.csv"
    cut.write_bytes(data[: data.rfind(b"\n", 0, len(data) - 400) + 1])  # whole rows removed
    with pytest.raises(RecordingError, match="Data Count"):
        open_recording(cut)


@pytest.mark.fast
def test_cetr_cut_mid_line(tmp_path):
    data = CETR1.read_bytes()
    cut = tmp_path / "cut.csv"
    cut.write_bytes(data[: len(data) - 420])
    with pytest.raises(RecordingError, match="truncated or corrupt"):
        open_recording(cut)


# -------------------------------------------------------------------- pin-on-disc
@pytest.mark.fast
@pytest.mark.parametrize(
    "path, load, first, last",
    [
        # rows at lines 17 and 1817: Test Time, Friction Force, Friction Coefficient, Distance
        (POD60, 59.841, (6.0, -0.3, -0.004507, 0.0), (1805.7, 7.0, 0.117191, 271.635)),
        (POD100, 98.1, (6.0, 0.0, 0.0, 0.0), (1805.7, 11.6, 0.118228, 271.484)),
    ],
)
def test_pin_on_disc(path, load, first, last):
    with open_recording(path) as rec:
        assert rec.format == "compend"
        assert rec.channel_names == POD_COLUMNS
        assert rec.metadata["text_columns"] == ["Time"]  # clock time, not a channel
        assert rec.n_samples == 1801  # lines 17..1817
        assert rec.fs == 1.0 and rec.duration == 1801.0
        assert rec.roles == {"fy": "Friction Force", "fz": "Load", "cof": "Friction Coefficient"}
        units = {c.name: c.unit for c in rec.channels}
        assert units["Load"] == units["Friction Force"] == "N" and units["Test Time"] == "s"
        assert rec.metadata["footer"][0].startswith("Test completed at")
        assert rec.warnings == []
        d = rec.read(["Test Time", "fy", "cof", "Distance", "fz", "Friction Force.1"])
        np.testing.assert_array_equal(d["fz"], load)
        np.testing.assert_array_equal(d["Friction Force.1"], d["fy"])  # the duplicate column
        for k, v0, v1 in zip(["Test Time", "fy", "cof", "Distance"], first, last):
            assert d[k][0] == v0 and d[k][-1] == v1


@pytest.mark.fast
@pytest.mark.parametrize("path, worst", [(POD60, 0.0064), (POD100, 0.0111)])
def test_pin_on_disc_cof_column_consistency(path, worst):
    """Friction Force / Load = Friction Coefficient within 2 % wherever |Ff| >= 2 N.

    The force is printed to 0.1 N, so at the start (|Ff| < 1 N) the ratio is
    off by up to 11 %; Load is constant, so "fz large enough" holds everywhere.
    """
    with open_recording(path) as rec:
        d = rec.read()
    ok = np.abs(d["fy"]) >= 2.0
    assert ok.sum() >= 1799
    rel = np.abs(d["fy"][ok] / d["fz"][ok] - d["cof"][ok]) / np.abs(d["cof"][ok])
    assert rel.max() < 0.02
    assert rel.max() == pytest.approx(worst, abs=5e-4)


@pytest.mark.fast
def test_pin_on_disc_cut_mid_line(tmp_path):
    data = POD60.read_bytes()
    cut = tmp_path / "cut.tsv"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError, match="truncated or corrupt"):
        open_recording(cut)
    cut.write_bytes(data[: data.rfind(b"\n", 0, len(data) // 2) + 1])  # whole rows: no footer
    with open_recording(cut) as rec:
        assert any("Test completed" in w for w in rec.warnings)


# ---------------------------------------------------------------------------- LVM
@pytest.mark.fast
def test_lvm_long_multi_segment():
    with open_recording(LVM_LONG) as rec:
        assert rec.format == "lvm"
        assert rec.channel_names == ["F", "m_1", "m_2"]
        assert rec.n_samples == 16384  # data rows, lines 23..16406 (the header says 8192)
        assert rec.segments == [(0, 8192), (8192, 16384)]
        assert any("announces 8192" in w for w in rec.warnings)
        assert rec.fs == pytest.approx(1 / 0.000977, rel=1e-11)  # rounded to 12 digits
        assert [c.unit for c in rec.channels] == ["g", "m/s^2", "m/s^2"]  # g not converted
        assert all(c.scale == 1.0 for c in rec.channels)
        d = rec.read(["F", "m_1", "m_2"])
        assert (d["F"][0], d["m_1"][0], d["m_2"][0]) == (0.052530, 0.234571, 0.244440)  # line 23
        assert (d["F"][-1], d["m_1"][-1], d["m_2"][-1]) == (0.052073, 0.235689, 0.263686)
        assert (d["F"][8192], d["m_1"][8192], d["m_2"][8192]) == (0.052115, 0.210231, 0.276808)
        assert d["m_2"][2475] == -5.458060e-6  # line 2498, exponent notation


@pytest.mark.fast
def test_lvm_short_decimal_comma():
    with open_recording(LVM_SHORT) as rec:
        assert rec.channel_names == ["Excitation (Trigger)", "Response (Trigger)"]
        assert rec.n_samples == 10
        assert rec.fs == 25600.0  # Delta_X 3,906250E-5
        assert rec.channels[0].raw_unit == "Newtons" and rec.channels[0].unit == "N"
        assert rec.metadata["header"]["Decimal_Separator"] == ","
        d = rec.read(["Excitation (Trigger)", "Response (Trigger)"])
        assert d["Excitation (Trigger)"][0] == 0.914018 and d["Response (Trigger)"][0] == 1.204792
        assert d["Excitation (Trigger)"][-1] == 0.680572 and d["Response (Trigger)"][-1] == 1.212775
    with open_recording(LVM_SHORT, channels={"fy": "Excitation (Trigger)"}) as rec:
        assert list(rec.read()) == ["fy"]


@pytest.mark.fast
def test_lvm_cut_mid_line(tmp_path):
    data = LVM_LONG.read_bytes()
    half = data[: len(data) // 2]
    cut = tmp_path / "cut.lvm"
    cut.write_bytes(half[: half.rfind(b"\t") + 4])  # inside the last field of a row
    with pytest.raises(RecordingError, match="incomplete"):
        open_recording(cut)
    cut.write_bytes(half[: half.rfind(b"\n") + 1] + b"\t0.0521\t0.2")  # fields missing
    with pytest.raises(RecordingError, match="truncated"):
        open_recording(cut)


LVM_VARIANTS = {
    # X_Columns Multi: an X column before each channel; header values sit in the data's columns
    "multi_x": (
        "LabVIEW Measurement\t\nWriter_Version\t2\nSeparator\tTab\nDecimal_Separator\t.\n"
        "Multi_Headings\tYes\nX_Columns\tMulti\n***End_of_Header***\t\n\t\n"
        "Channels\t2\t\t\t\nSamples\t3\t\t3\t\nY_Unit_Label\tVolts\t\tmN\t\n"
        "Delta_X\t1.953125E-5\t\t1.953125E-5\t\n***End_of_Header***\t\t\t\t\n"
        "X_Value\tVoltage\tX_Value\tForce\tComment\n"
        "0.000000\t-0.035229\t0.000000\t0.532608\n"
        "1.953125E-5\t-0.034882\t1.953125E-5\t0.502991\n"
        "3.906250E-5\t-0.034191\t3.906250E-5\t0.467541\n\n"
    ),
    # two segments, each with its own header, a comment column and empty channels
    "two_segments": (
        "LabVIEW Measurement\nSeparator\tTab\nDecimal_Separator\t.\nMulti_Headings\tYes\n"
        "X_Columns\tOne\n***End_of_Header***\n\n"
        "Notes\tsome note\nChannels\t3\nSamples\t2\t0\t2\nY_Unit_Label\tN\t\tN\n"
        "Delta_X\t0.001000\t1.000000\t0.001000\n***End_of_Header***\n"
        "X_Value\tfz\tUntitled\tfy\tComment\n"
        "0.000000\t-1.5\t\t0.3\tOK\n0.001000\t-1.6\t\t0.31\tLOST COMMUNICATION\n\n"
        "Channels\t3\nSamples\t2\t0\t2\nY_Unit_Label\tN\t\tN\n"
        "Delta_X\t0.001000\t1.000000\t0.001000\n***End_of_Header***\n"
        "X_Value\tfz\tUntitled\tfy\tComment\n"
        "0.002000\t-1.7\t\t0.32\n0.003000\t-1.8\t\t\n"
    ),
}


@pytest.mark.fast
def test_lvm_variants(tmp_path):
    p = tmp_path / "multi.lvm"
    p.write_text(LVM_VARIANTS["multi_x"])
    with open_recording(p) as rec:
        assert rec.channel_names == ["Voltage", "Force"]
        assert rec.fs == 51200.0
        assert [c.unit for c in rec.channels] == ["V", "N"]
        d = rec.read(["Voltage", "Force"])
        np.testing.assert_array_equal(d["Voltage"], [-0.035229, -0.034882, -0.034191])
        np.testing.assert_allclose(d["Force"], [0.532608e-3, 0.502991e-3, 0.467541e-3], rtol=1e-15)
    p = tmp_path / "two.lvm"
    p.write_text(LVM_VARIANTS["two_segments"])
    with open_recording(p) as rec:
        assert rec.channel_names == ["fz", "fy"]  # "Untitled" announced empty: skipped
        assert rec.metadata["skipped"] == ["Untitled"]
        assert rec.segments == [(0, 2), (2, 4)]
        assert rec.roles == {"fy": "fy", "fz": "fz"}
        assert rec.fs == 1000.0
        d = rec.read()
        np.testing.assert_array_equal(d["fz"], [-1.5, -1.6, -1.7, -1.8])
        np.testing.assert_array_equal(d["fy"], [0.3, 0.31, 0.32, np.nan])  # empty field: NaN
        got = _chunked(rec, 3)
        np.testing.assert_array_equal(got["fy"], d["fy"])


@pytest.mark.fast
def test_lvm_never_writes_beside_the_file(tmp_path):
    p = tmp_path / "short.lvm"
    p.write_bytes(LVM_SHORT.read_bytes())
    with open_recording(p) as rec:
        rec.read()
    assert sorted(os.listdir(tmp_path)) == ["short.lvm"]


# --------------------------------------------------------------------------- TDMS
@pytest.mark.fast
def test_tdms_daqmx_scaled():
    from nptdms import TdmsFile

    ref = TdmsFile.read(TDMS)
    group = ref["Layer Data"]
    with open_recording(TDMS) as rec:
        assert rec.format == "tdms"
        assert rec.channel_names == TDMS_COLUMNS
        assert rec.n_samples == 2000
        assert rec.fs == 50000.0  # 1 / wf_increment (1.9999999999999998e-05)
        assert all((c.raw_unit, c.unit) == ("Volts", "V") for c in rec.channels)
        d = rec.read(TDMS_COLUMNS)
        for name in TDMS_COLUMNS:
            ch = group[name]
            np.testing.assert_array_equal(d[name], ch[:])
            # npTDMS applied the DAQmx linear scale to the int16 raw data
            raw = ch.read_data(scaled=False)
            raw = next(iter(raw.values())) if isinstance(raw, dict) else raw
            assert raw.dtype == np.int16
            slope = ch.properties["NI_Scale[1]_Linear_Slope"]
            icpt = ch.properties["NI_Scale[1]_Linear_Y_Intercept"]
            np.testing.assert_allclose(d[name], raw * slope + icpt, rtol=1e-12, atol=1e-15)
        assert d["First  Channel"][0] == pytest.approx(-603 * 0.0003051850947599719)
    # group/channel names are accepted too
    with open_recording(TDMS, channels={"u": "Layer Data/Second Chan", "i": "/Third Chan"}) as rec:
        assert rec.roles == {"u": "Second Chan", "i": "Third Chan"}


@pytest.mark.fast
def test_tdms_truncated(tmp_path):
    data = TDMS.read_bytes()
    cut = tmp_path / "half.tdms"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError, match="truncated TDMS"):
        open_recording(cut)
    cut.write_bytes(data[:20])
    with pytest.raises(RecordingError, match="truncated TDMS"):
        open_recording(cut)


@pytest.mark.fast
def test_tdms_groups_and_lengths(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    p = tmp_path / "g.tdms"
    props = {"wf_increment": 0.001}
    with TdmsWriter(str(p)) as w:
        w.write_segment(
            [
                ChannelObject("a", "fy", np.arange(5.0), properties=props),
                ChannelObject("b", "fy", np.arange(5.0) + 10, properties=props),
                ChannelObject("b", "short", np.arange(3.0), properties=props),
            ]
        )
    with pytest.raises(RecordingError, match="unequal channel lengths"):
        open_recording(p)
    with open_recording(p, channels={"fy": "b/fy"}) as rec:
        assert rec.channel_names == ["a/fy", "b/fy"]  # name not unique: group/channel
        assert rec.metadata["skipped"] == ["short"]
        np.testing.assert_array_equal(rec.read()["fy"], np.arange(5.0) + 10)


# ---------------------------------------------------------------------------- npy
@pytest.mark.fast
def test_npy_real():
    a = np.load(NPY)
    with pytest.raises(RecordingError, match="pass fs="):
        open_recording(NPY)
    with open_recording(NPY, fs=25600) as rec:
        assert rec.format == "npy"
        assert rec.channel_names == ["ch0", "ch1", "ch2"]
        assert rec.n_samples == 25600 and rec.duration == 1.0
        d = rec.read(["ch0", "ch1", "ch2"])
        for k in range(3):
            np.testing.assert_array_equal(d[f"ch{k}"], a[k])
    with open_recording(NPY, time_channel="ch0", channels={"fz": "ch1"}) as rec:
        assert rec.fs == 25600.0  # median step of the time row
        assert list(rec.read()) == ["fz"]


@pytest.mark.fast
def test_npy_layout(tmp_path):
    a = np.load(NPY)
    p = tmp_path / "t.npy"
    np.save(p, np.ascontiguousarray(a.T))  # (25600, 3): samples x channels by the 10x rule
    with open_recording(p, fs=25600) as rec:
        assert rec.metadata["layout"] == "samples_first"
        np.testing.assert_array_equal(rec.read(["ch2"])["ch2"], a[2])
        np.testing.assert_array_equal(_chunked(rec, 1000, ["ch2"])["ch2"], a[2])
    with open_recording(p, fs=1, layout="channels_first") as rec:
        assert rec.n_samples == 3 and len(rec.channels) == 25600
    p1 = tmp_path / "one.npy"
    np.save(p1, np.arange(10, dtype=np.int16))
    with open_recording(p1, fs=1, names=["fy"]) as rec:
        assert rec.roles == {"fy": "fy"}
        assert rec.read()["fy"].dtype == np.float64


@pytest.mark.fast
def test_npy_truncated(tmp_path):
    data = NPY.read_bytes()
    cut = tmp_path / "cut.npy"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError, match="truncated"):
        open_recording(cut, fs=1)


# ------------------------------------------------------------------ round trips
def _signals(n=1234):
    rng = np.random.default_rng(1)
    t = np.arange(n) / 2000.0
    fz = -10 + rng.standard_normal(n)
    return {"fy": -0.3 * fz + 0.01 * np.sin(t), "fz": fz, "i": rng.standard_normal(n)}


@pytest.mark.fast
@pytest.mark.parametrize(
    "writer, suffix, kw",
    [
        (save_npz, ".npz", {}),
        (save_npz, ".npz", {"compress": True}),
        (save_hdf5, ".h5", {}),
        (save_tdms, ".tdms", {}),
        (save_tdms, ".tdms", {"segment_samples": 100}),
    ],
)
def test_writer_round_trip(tmp_path, writer, suffix, kw):
    sig = _signals()
    p = tmp_path / f"rec{suffix}"
    writer(p, sig, 2000.0, {"fy": "N", "fz": "N", "i": "A"}, **kw)
    assert sorted(os.listdir(tmp_path)) == [p.name]  # no temp file left
    with open_recording(p) as rec:
        assert rec.channel_names == ["fy", "fz", "i"]
        assert rec.roles == {"fy": "fy", "fz": "fz", "i": "i"}
        assert rec.fs == 2000.0
        assert [c.unit for c in rec.channels] == ["N", "N", "A"]
        d = rec.read()
        for k, v in sig.items():
            np.testing.assert_array_equal(d[k], v)
        for size in (1, 7, 1000, 5000):
            got = _chunked(rec, size)
            for k, v in sig.items():
                np.testing.assert_array_equal(got[k], v)


@pytest.mark.fast
def test_npy_writer_round_trip(tmp_path):
    sig = _signals(500)
    p = tmp_path / "rec.npy"
    names = save_npy(p, sig)
    assert names == ["fy", "fz", "i"]
    with open_recording(p, fs=2000.0) as rec:
        d = rec.read([f"ch{k}" for k in range(3)])
        for k, name in enumerate(names):
            np.testing.assert_array_equal(d[f"ch{k}"], sig[name])


@pytest.mark.fast
def test_writers_reject_bad_input(tmp_path):
    with pytest.raises(ValueError, match="samples"):
        save_npz(tmp_path / "x.npz", {"fy": np.zeros(3), "fz": np.zeros(4)}, 1.0)
    with pytest.raises(ValueError, match="fs"):
        save_hdf5(tmp_path / "x.h5", {"fy": np.zeros(3)}, 0.0)
    with pytest.raises(ValueError, match="reserved"):
        save_npz(tmp_path / "x.npz", {"fs": np.zeros(3)}, 1.0)
    assert os.listdir(tmp_path) == []


# ----------------------------------------------------------------- HDF5 / npz
@pytest.mark.fast
def test_hdf5_layout_and_fs_sources(tmp_path):
    p = tmp_path / "nested.hdf5"
    with h5py.File(p, "w") as f:
        g = f.create_group("run1/forces")
        g.attrs["dt"] = 1e-3
        g.create_dataset("Fn", data=np.arange(6.0)).attrs["units"] = "kN"
        g.create_dataset("Ft", data=np.arange(6.0) / 10).attrs["unit"] = b"N"
        f.create_dataset("meta/table", data=np.zeros((6, 2)))
        f.create_dataset("meta/short", data=np.zeros(2))
    with open_recording(p, channels={"fz": "Fn", "fy": "run1/forces/Ft"}) as rec:
        assert rec.channel_names == ["run1/forces/Fn", "run1/forces/Ft"]
        assert rec.fs == 1000.0
        assert sorted(rec.metadata["skipped"]) == ["meta/short", "meta/table"]
        fz = rec.channels[0]
        assert (fz.raw_unit, fz.unit, fz.scale) == ("kN", "N", 1000.0)
        np.testing.assert_array_equal(rec.read()["fz"], np.arange(6.0) * 1000)
    with pytest.raises(RecordingError, match="unequal channel lengths"):
        open_recording(p)  # no mapping: Fn/Ft (6) vs meta/short (2)


@pytest.mark.fast
def test_hdf5_truncated(tmp_path):
    p = tmp_path / "rec.h5"
    save_hdf5(p, _signals(20000), 100.0)
    data = p.read_bytes()
    cut = tmp_path / "cut.h5"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError), open_recording(cut) as rec:
        rec.read()


@pytest.mark.fast
def test_npz_unequal_lengths_and_missing_fs(tmp_path):
    p = tmp_path / "u.npz"
    np.savez(p, fy=np.zeros(5), fz=np.ones(5), other=np.zeros(3))
    with pytest.raises(RecordingError, match="unequal channel lengths"):
        open_recording(p, fs=1)
    with pytest.raises(RecordingError, match="sampling rate unknown"):
        open_recording(p, channels={"fy": "fy"})
    with open_recording(p, fs=10, channels={"fy": "fy"}) as rec:
        assert rec.channel_names == ["fy", "fz"] and rec.metadata["skipped"] == ["other"]
        assert rec.streaming


@pytest.mark.fast
def test_npz_corrupt(tmp_path):
    p = tmp_path / "rec.npz"
    save_npz(p, _signals(), 10.0)
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])
    with pytest.raises(RecordingError, match="npz"):
        open_recording(p)


# ------------------------------------------------------------- generic text
@pytest.mark.fast
def test_csv_generic(tmp_path):
    p = tmp_path / "run.csv"
    p.write_text(
        "# rig 3, pin 2\nTime (ms);Fz [N];Fy [N];note\n"
        + "".join(f"{k * 0.5:.1f};{-10 - k:.2f};{3 + k / 10:.3f};ok\n".replace(".", ",") for k in range(9))
    )
    with open_recording(p) as rec:
        assert rec.format == "delimited"
        assert rec.metadata["delimiter"] == ";" and rec.metadata["decimal"] == ","
        assert rec.channel_names == ["Time (ms)", "Fz [N]", "Fy [N]"]
        assert rec.metadata["text_columns"] == ["note"]
        assert rec.fs == 2000.0  # 0.5 ms steps
        assert rec.roles == {"fy": "Fy [N]", "fz": "Fz [N]"}
        tm = rec.channels[0]
        assert (tm.raw_unit, tm.unit, tm.scale) == ("ms", "s", 1e-3)
        d = rec.read()
        np.testing.assert_allclose(d["fz"], -10.0 - np.arange(9))
        np.testing.assert_allclose(d["fy"], 3 + np.arange(9) / 10)


@pytest.mark.fast
def test_csv_units_row_and_blocks(tmp_path):
    p = tmp_path / "blocks.txt"
    p.write_text("t,fy,fz\ns,kN,kN\n0,1,2\n0.1,1.5,2.5\n\nrepeat 2\nt,fy,fz\ns,kN,kN\n0,3,4\n0.1,3.5,4.5\n0.2,4,5\n")
    with open_recording(p) as rec:
        assert rec.segments == [(0, 2), (2, 5)]
        assert rec.fs == 10.0
        np.testing.assert_array_equal(rec.read()["fy"], [1e3, 1.5e3, 3e3, 3.5e3, 4e3])


@pytest.mark.fast
def test_csv_needs_fs_without_time_column(tmp_path):
    p = tmp_path / "x.tsv"
    p.write_text("fy\tfz\n1\t2\n3\t4\n")
    with pytest.raises(RecordingError, match="pass fs="):
        open_recording(p)
    with open_recording(p, fs=5) as rec:
        np.testing.assert_array_equal(rec.read()["fz"], [2.0, 4.0])


@pytest.mark.fast
def test_csv_corrupt_row(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("fy,fz\n" + "1,2\n" * 10 + "1,x\n" + "1,2\n" * 10)
    with open_recording(p, fs=1) as rec, pytest.raises(RecordingError, match="line 12"):
        rec.read()


# ---------------------------------------------------------------------- errors
@pytest.mark.fast
def test_error_missing_file(tmp_path):
    with pytest.raises(RecordingError, match="no such file"):
        open_recording(tmp_path / "nope.tdms")


@pytest.mark.fast
def test_error_unknown_format(tmp_path):
    p = tmp_path / "x.bin"
    p.write_bytes(bytes(range(256)) * 4)
    with pytest.raises(RecordingError, match="unknown format"):
        open_recording(p)
    with pytest.raises(RecordingError, match="unknown format"):
        open_recording(LVM_SHORT, format="wav")
    p = tmp_path / "words.txt"
    p.write_text("no numbers here\njust words\n")
    with pytest.raises(RecordingError, match="no table of numbers"):
        open_recording(p)
    p = tmp_path / "fake.tdms"
    p.write_text("a,b\n1,2\n")
    with pytest.raises(RecordingError, match="not a valid tdms"):
        open_recording(p)


@pytest.mark.fast
def test_error_missing_channel_lists_available():
    with pytest.raises(RecordingError) as e:
        open_recording(CETR1, channels={"fy": "Friction"})
    msg = str(e.value)
    assert "'Friction'" in msg and "'Fx'" in msg and "'COF'" in msg and "\n" not in msg
    with open_recording(CETR1) as rec:
        with pytest.raises(RecordingError, match="available channels: 'Fx'"):
            rec.chunks(10, ["fx"])  # fx is not mapped for CETR (Fx is the friction force)
        with pytest.raises(RecordingError, match=">= 1"):
            rec.chunks(0)


@pytest.mark.fast
def test_error_bad_options():
    with pytest.raises(TypeError, match="option"):
        open_recording(LVM_SHORT, delimiter=",")
    with pytest.raises(RecordingError, match="fs must be"):
        open_recording(NPY, fs=-1)


# ------------------------------------------------------------------- streaming
def _peak_while_chunking(path: Path, **kw) -> int:
    with open_recording(path, **kw) as rec:
        tracemalloc.start()
        try:
            total = sum(len(c["fy"]) for c in rec.chunks(4096, ["fy", "fz"]))
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert total == rec.n_samples
    return peak


@pytest.mark.fast
def test_chunks_memory_is_bounded_binary(tmp_path):
    n = 600_000
    sig = {"fy": np.linspace(0, 1, n), "fz": np.linspace(1, 2, n)}
    full_bytes = 2 * n * 8  # 9.6 MB
    for writer, suffix in ((save_npz, ".npz"), (save_hdf5, ".h5"), (save_tdms, ".tdms")):
        p = tmp_path / f"big{suffix}"
        writer(p, sig, 1000.0)
        assert _peak_while_chunking(p) < full_bytes / 3, p.name  # about 2.2 MB
    p = tmp_path / "big.npy"
    save_npy(p, sig)
    assert _peak_while_chunking(p, fs=1000.0, names=["fy", "fz"]) < full_bytes / 3


def _write_csv(path: Path, m: int) -> None:
    t = np.arange(m) / 1000.0
    with open(path, "w") as f:
        f.write("time,fy,fz\n")
        np.savetxt(f, np.column_stack([t, np.sin(t), np.cos(t)]), fmt="%.6f", delimiter=",")


def _write_lvm(path: Path, m: int) -> None:
    t = np.arange(m) / 1000.0
    with open(path, "w") as f:
        f.write(
            "LabVIEW Measurement\t\nSeparator\tTab\nDecimal_Separator\t,\nX_Columns\tNo\n"
            "***End_of_Header***\t\n\t\nChannels\t2\t\t\nDelta_X\t1,0E-3\t1,0E-3\t\n"
            "***End_of_Header***\t\t\t\nX_Value\tfy\tfz\tComment\n"
        )
        rows = np.column_stack([np.sin(t), np.cos(t)])
        f.write("".join(f"\t{a:.6f}\t{b:.6f}\n" for a, b in rows).replace(".", ","))


@pytest.mark.fast
@pytest.mark.parametrize("writer, suffix", [(_write_csv, ".csv"), (_write_lvm, ".lvm")])
def test_chunks_memory_is_bounded_text(tmp_path, writer, suffix):
    """The peak while chunking a text file does not grow with the file's length."""
    small, big = tmp_path / f"small{suffix}", tmp_path / f"big{suffix}"
    writer(small, 20_000)  # > 2 text blocks of 8192 lines
    writer(big, 60_000)
    p_small, p_big = _peak_while_chunking(small), _peak_while_chunking(big)
    assert p_big < 1.3 * p_small, (p_small, p_big)


# ---------------------------------------------------------------------- writers
@pytest.mark.fast
def test_atomic_write_leaves_nothing_on_error(tmp_path):
    target = tmp_path / "out.bin"

    def boom(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(b"partial")
        raise RuntimeError("disk on fire")

    with pytest.raises(RuntimeError, match="disk on fire"):
        atomic_write(target, boom)
    assert os.listdir(tmp_path) == []
    target.write_bytes(b"old")
    with pytest.raises(RuntimeError):
        atomic_write(target, boom)
    assert target.read_bytes() == b"old" and os.listdir(tmp_path) == ["out.bin"]

    def good(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            fh.write(b"new content")

    atomic_write(target, good)
    assert target.read_bytes() == b"new content" and os.listdir(tmp_path) == ["out.bin"]
    assert sha256_file(target) == hashlib.sha256(b"new content").hexdigest()


@pytest.mark.fast
def test_sha256_file_is_hashlibs_at_every_step_size(tmp_path):
    """The native digest (``_core.FileDigest``, issue 38 point 3) equals hashlib's, whatever the step size."""
    rng = np.random.default_rng(7)
    for size in (0, 1, 63, 64, 65, 4096, (1 << 20) + 3):
        path = tmp_path / f"f{size}.bin"
        data = rng.integers(0, 256, size, dtype=np.uint8).tobytes()
        path.write_bytes(data)
        want = hashlib.sha256(data).hexdigest()
        for step in (1, 64, 1 << 20, 1 << 26):
            if size // step > 5000:
                continue
            assert sha256_file(path, step) == want, (size, step)
    with pytest.raises(FileNotFoundError):
        sha256_file(tmp_path / "missing.bin")
    with pytest.raises(IsADirectoryError):
        sha256_file(tmp_path)


@pytest.mark.fast
def test_digests_thread_gives_each_files_sha256_and_stops_when_cancelled(tmp_path):
    from tribodyn.app.outputs import Digests

    paths = []
    for k in range(3):
        p = tmp_path / f"in{k}.bin"
        p.write_bytes(bytes([k]) * (1000 + k))
        paths.append(p)
    d = Digests(paths)
    assert [d.get(p) for p in paths] == [hashlib.sha256(p.read_bytes()).hexdigest() for p in paths]
    stopped = Digests(paths)
    stopped.cancel()
    assert stopped.get(paths[2]) == hashlib.sha256(paths[2].read_bytes()).hexdigest()  # computed here if not there
    missing = Digests([tmp_path / "gone.bin"])
    with pytest.raises(FileNotFoundError):
        missing.get(tmp_path / "gone.bin")


@pytest.mark.fast
@pytest.mark.parametrize("name", sorted(p.name for p in (TESTS / "data" / "real").iterdir()))
def test_chunks_of_a_sample_range_equal_the_slice(name):
    """chunks(start=, stop=) reads only part of a recording (used to split long recordings)."""
    import tribodyn

    path = TESTS / "data" / "real" / name
    kw = {"fs": 25600.0} if name.endswith(".npy") else {}
    with tribodyn.open_recording(path, **kw) as rec:
        full = rec.read()
        a, b = rec.n_samples // 3, rec.n_samples - rec.n_samples // 4
        parts = list(rec.chunks(7, start=a, stop=b))
        for key, whole in full.items():
            np.testing.assert_array_equal(np.concatenate([p[key] for p in parts]), whole[a:b])
        with pytest.raises(tribodyn.RecordingError, match="start/stop"):
            rec.chunks(7, start=b, stop=a)


@pytest.mark.fast
@pytest.mark.parametrize("name", ["allow_pickle", "file"])
def test_save_npz_refuses_names_of_savez_arguments(tmp_path, name):
    from tribodyn.io.writers import save_npz

    with pytest.raises(ValueError, match="reserved"):
        save_npz(tmp_path / "x.npz", {name: np.arange(4.0), "fy": np.arange(4.0)}, 10.0)
    assert not (tmp_path / "x.npz").exists()


@pytest.mark.fast
def test_an_open_recording_is_not_pickled_and_says_to_send_its_path(tmp_path: Path) -> None:
    """Sent to a worker process (multiprocessing, a process pool), an open recording says what to send instead of
    pickle's "cannot pickle '_thread.lock' object" (issue 38 audit)."""
    import copy
    import pickle

    path = tmp_path / "rec.npy"
    np.save(path, np.zeros((3, 100)))
    with tribodyn.open_recording(path, fs=1000.0, names=["fx", "fy", "fz"]) as rec:
        for attempt in (lambda: pickle.dumps(rec), lambda: copy.copy(rec)):
            with pytest.raises(TypeError, match=r"rec\.npy\) cannot be pickled or copied: send its path"):
                attempt()
