#!/usr/bin/env bash
# Downloads (here, where PyPI is reachable) the wheels that benches/device_scaling.py may need on a bare
# machine that cannot download anything: numpy, h5py, npTDMS, dask, distributed and their dependencies,
# built for CPython 3.12 on x86-64 Linux (the device's python3; pass another version as $1, e.g. 3.11).
# About 27 MB; no pandas, pyarrow or scipy (the benches do not import them).
#
#   bash benches/make_wheelhouse.sh            # -> .whl/ in the repository's root, ignored by git
#   bash benches/make_wheelhouse.sh 3.12 DIR   # another folder
#
# The folder is added to .git/info/exclude (local, never committed) so that it travels only when a
# device run names it in `carry` (see the README of the device tool and benches/RESULTS.md).
set -euo pipefail
PYV="${1:-3.12}"
ROOT="$(git rev-parse --show-toplevel)"
DEST="${2:-$ROOT/.whl}"
TAG="cp${PYV/./}"
# Versions known to work together with tribodyn here (python -m pip list on the development machine).
PKGS=("numpy==2.4.6" "h5py==3.16.0" "npTDMS==1.13.0" "dask==2026.8.0" "distributed==2026.8.0")
mkdir -p "$DEST"
python3 -m pip download -q --only-binary=:all: --python-version "$PYV" --implementation cp --abi "$TAG" \
    --platform manylinux_2_28_x86_64 --platform manylinux_2_27_x86_64 --platform manylinux_2_17_x86_64 \
    --platform manylinux2014_x86_64 --platform manylinux_2_12_x86_64 --platform manylinux2010_x86_64 \
    --platform manylinux_2_5_x86_64 --platform manylinux1_x86_64 \
    -d "$DEST" "${PKGS[@]}"
case "$DEST" in
"$ROOT"/*)
    rel="/${DEST#"$ROOT"/}/"
    exclude="$(git rev-parse --git-path info/exclude)"
    mkdir -p "$(dirname "$exclude")"
    grep -qxF "$rel" "$exclude" 2>/dev/null || echo "$rel" >>"$exclude"
    ;;
esac
ls "$DEST"
du -sh "$DEST"
# One version of each distribution, or pip refuses the whole install there.
dups="$(ls "$DEST" | sed 's/-[0-9].*//' | tr 'A-Z_' 'a-z-' | sort | uniq -d)"
if [ -n "$dups" ]; then
    echo "more than one version of: $dups (delete the older wheels)" >&2
    exit 1
fi
