"""Shared pytest configuration: Hypothesis settings profiles.

``default`` is used for local runs.  ``ci`` is loaded when the environment variable
``CI`` is set to a true value (``CI=true`` on the continuous-integration runner); it is
derandomised so that a CI run is reproducible, and keeps no example database.  ``thorough`` is for
a long run by hand (``pytest --hypothesis-profile=thorough tests/test_engine_equality.py``): twenty
times the examples of ``default``.
"""

import os

from hypothesis import HealthCheck, settings

settings.register_profile(
    "default",
    max_examples=100,
    deadline=None,
)
settings.register_profile(
    "ci",
    max_examples=100,
    deadline=None,
    derandomize=True,
    database=None,
    print_blob=True,
    suppress_health_check=[HealthCheck.too_slow],
)

settings.register_profile(
    "thorough",
    max_examples=2000,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
)

_ci = os.environ.get("CI", "").strip().lower() in {"1", "true", "yes", "on"}
settings.load_profile("ci" if _ci else "default")
