"""Where the repository's files are, for tests in any layer's folder (tests/<layer>/test_*.py)."""

from pathlib import Path

TESTS = Path(__file__).resolve().parent  # tests/: its data/ holds the recordings the tests read
REPO = TESTS.parent  # the repository's root: benches/, examples/, docs/
