"""tribodyn in a notebook: short repr, HTML view, DataFrame with units, Parquet units, accessors, keywords."""

from __future__ import annotations

import html
import warnings

import numpy as np
import pytest
import tribodyn as td
from tribodyn import columns, simulate


@pytest.fixture(scope="module")
def res() -> td.Results:
    sim = simulate.current_density_test(seed=3)
    return td.analyze(sim.channels, fs=sim.fs, window=2, hop=10, area_mm2=sim.area_mm2)


def test_repr_is_one_short_line(res):
    text = repr(res)
    assert "\n" not in text and len(text) <= 300
    assert f"{len(res)} windows" in text and "gated" in text and res.headline.short in text


def test_repr_html_has_the_headline_and_first_rows(res):
    page = res._repr_html_()
    assert "COF" in page and "95 % interval" in page
    assert page.count("<tr>") == 1 + min(len(res), 5)  # header + first rows
    assert "A/mm²" in page and "time (s)" in page
    assert html.escape(res.headline.text) in page  # the one headline (issue 21), then the verdict
    assert html.escape(td.results.verdict_text(res.verdict)) in page


def test_to_pandas_index_and_units(res):
    df = res.to_pandas()
    assert df.index.name == "time" and len(df) == len(res)
    np.testing.assert_array_equal(df.index.to_numpy(), res["time"])
    assert df.attrs["units"]["time"] == "s" and df.attrs["units"]["J"] == columns.UNITS["J"]
    assert set(df.columns) <= set(df.attrs["units"])


def test_parquet_field_units_round_trip(res, tmp_path):
    pq = pytest.importorskip("pyarrow.parquet")
    from tribodyn.app.outputs import write_table_parquet

    path = tmp_path / "w.parquet"
    assert write_table_parquet(res, path)
    schema = pq.read_schema(path)
    for name in ("time", "mu_r", "J", "T"):
        assert schema.field(name).metadata[b"unit"].decode() == columns.UNITS[name]


def test_gated_is_a_property_and_the_old_call_still_works(res):
    mask = res.gated
    assert mask.dtype == bool and mask.shape == (len(res),)
    assert type(mask & True) is np.ndarray  # arithmetic gives plain arrays
    with pytest.warns(DeprecationWarning, match="property"):
        old = res.gated()
    np.testing.assert_array_equal(old, mask)


def test_keyword_only_options_old_positional_forms_warn():
    x = np.sin(np.arange(2000) * 0.01) + 1.0
    new = td.highpass(x, fs=1000.0)
    with pytest.warns(DeprecationWarning, match="fs="):
        old = td.highpass(x, 1000.0)
    np.testing.assert_array_equal(new, old)
    fy, fz = 0.2 * x + 0.01 * np.cos(np.arange(2000)), x
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        a = td.identify(fy, fz, fs=1000.0)
    with pytest.warns(DeprecationWarning, match="identify"):
        b = td.identify(None, fy, fz, fs=1000.0)
    assert a.mu_r == b.mu_r
    with pytest.raises(TypeError, match="fs"):
        td.highpass(x)
