"""Objects a lab user sends between processes: an open Recording to a Pool worker (pickled, fork and spawn), and
Results back from it (with and without its cached values computed); compared with the parent's."""
import multiprocessing as mp
import pickle
import sys

import numpy as np
import tribodyn

import _common


def analyse_rec(rec):
    return tribodyn.analyze(rec)


def analyse_path(path):
    res = tribodyn.analyze(path)
    if "warm" in sys.argv:
        res.summary()
    return res


if __name__ == "__main__":
    ctx = mp.get_context(sys.argv[1])
    paths = [f for f in _common.FILES if not f.endswith(".npy")]
    here = [tribodyn.analyze(p) for p in paths]
    with ctx.Pool(2) as pool:
        got = pool.map(analyse_path, paths)
    for a, b in zip(here, got):
        assert _common.same(dict(a.table), dict(b.table)), "table"
        assert str(a.headline) == str(b.headline), (a.headline, b.headline)
        assert a.summary() == b.summary() or print("summary differs", a.summary().keys())
    print("Results back from workers: equal")
    recs = [tribodyn.open_recording(p) for p in paths]
    try:
        blob = pickle.dumps(recs[0])
        print("an open Recording pickles:", len(blob), "bytes")
    except Exception as exc:  # noqa: BLE001
        print("an open Recording does not pickle:", type(exc).__name__, str(exc)[:200])
    try:
        with ctx.Pool(2) as pool:
            got = pool.map(analyse_rec, recs)
        print("recordings sent to workers:", all(_common.same(dict(a.table), dict(b.table)) for a, b in zip(here, got)))
    except Exception as exc:  # noqa: BLE001
        print("sending recordings to workers:", type(exc).__name__, str(exc)[:300])
