"""Shared test set-up: hypothesis profiles and the markers that tier the suite.

Profiles (``HYPOTHESIS_PROFILE=<name> python -m pytest``): ``ci`` (the default, what CI runs;
the same examples every run), ``quick`` (a few examples per property, for a fast local loop) and
``thorough`` (many, new ones each run, before a release or after touching the engine).  A
test that needs a different number of examples than the profile gives scales it with
:func:`examples`.

Markers: ``slow`` (seconds each: the full shell, large meshes) and ``cluster`` (starts Dask
workers).  CI runs everything; ``-m "not slow and not cluster"`` is the quick local loop.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, Phase, settings

#: No "explain" phase: on the trees drawn here, explaining a failure can take minutes and 11 GB
#: (enough to stall a CI run); the shrunk example and its error are reported without it.
_COMMON = dict(deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                     HealthCheck.data_too_large,
                                                     HealthCheck.filter_too_much],
               phases=[p for p in Phase if p is not Phase.explain])
#: CI draws the same examples on every run (seeded by each test), so a clean clone that passes
#: here passes there; ``thorough`` explores afresh each time.
settings.register_profile("ci", max_examples=60, derandomize=True, **_COMMON)
settings.register_profile("quick", max_examples=12, **_COMMON)
settings.register_profile("thorough", max_examples=500, **_COMMON)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def examples(fraction: float) -> settings:
    """Settings with ``fraction`` of the profile's examples (at least 3), for costly properties."""
    return settings(max_examples=max(3, round(settings.default.max_examples * fraction)))
