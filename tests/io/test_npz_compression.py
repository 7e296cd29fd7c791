""".npz members zipfile cannot read (issue 21): an unknown compression method or a corrupt compressed stream is a
RecordingError (the CLI: one line, exit 2), never a NotImplementedError or zlib.error traceback."""

from __future__ import annotations

import struct
import zipfile
import zlib

import numpy as np
import pytest
import tribodyn as td
from tribodyn.app.cli import main
from tribodyn.io import RecordingError


def _npz_with_method(path, method):
    """A numpy .npz whose members claim compression ``method`` in the local and central headers."""
    np.savez(path, fy=np.ones(500), fz=np.full(500, 10.0), fs=np.array(100.0))
    b = bytearray(path.read_bytes())
    for sig, at in ((b"PK\x03\x04", 8), (b"PK\x01\x02", 10)):  # local header, central directory entry
        i = b.find(sig)
        while i != -1:
            b[i + at : i + at + 2] = struct.pack("<H", method)
            i = b.find(sig, i + 4)
    path.write_bytes(bytes(b))
    with zipfile.ZipFile(path) as z:  # the crafted file says what the test means
        assert {zi.compress_type for zi in z.infolist()} == {method}


@pytest.mark.fast
def test_npz_unknown_compression_method_is_a_recording_error(tmp_path):
    p = tmp_path / "m99.npz"
    _npz_with_method(p, 99)
    with pytest.raises(RecordingError, match=r"member 'fy\.npy' uses a compression method that cannot be read"):
        td.open_recording(p)


@pytest.mark.fast
def test_cli_unknown_compression_method_one_line_exit_2(tmp_path, capsys):
    p = tmp_path / "m99.npz"
    _npz_with_method(p, 99)
    assert main(["info", str(p)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "compression method" in err and "Traceback" not in err
    out = tmp_path / "out"
    assert main(["analyze", str(p), "--out", str(out), "--quiet"]) == 2
    assert not out.exists()
    assert "Traceback" not in capsys.readouterr().err


@pytest.mark.fast
def test_npz_decompression_error_while_reading_is_a_recording_error(tmp_path, monkeypatch):
    p = tmp_path / "ok.npz"
    np.savez_compressed(p, fy=np.ones(5000), fz=np.full(5000, 10.0), fs=np.array(100.0))
    rec = td.open_recording(p)
    real = zipfile.ZipExtFile.read

    def broken(self, n=-1):
        if n > 1000:  # the data, not the .npy header
            raise zlib.error("Error -3 while decompressing data: invalid distance too far back")
        return real(self, n)

    monkeypatch.setattr(zipfile.ZipExtFile, "read", broken)
    with pytest.raises(RecordingError, match=r"corrupt member 'fy'.*invalid distance"):
        rec.read(["fy"])
    rec.close()
