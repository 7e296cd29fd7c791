"""Shared test configuration: hypothesis profiles.

"ci" (loaded when the CI environment variable is set): few examples, no
deadline, derandomized so a CI run is reproducible. "dev" otherwise: more
examples, random seeds, still no deadline (the first call of a kernel may
spin up the thread pool, which would trip a per-example deadline).
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", max_examples=40, deadline=None, derandomize=True)
settings.register_profile("dev", max_examples=100, deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
