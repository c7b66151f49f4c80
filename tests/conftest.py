"""Suite-wide settings: hypothesis profiles and a private cache of decoded trials."""

import os

import pytest
from hypothesis import HealthCheck, settings

# Property tests run a bounded number of examples in CI; HYPOTHESIS_PROFILE=thorough runs more.
settings.register_profile("ci", max_examples=100, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("thorough", max_examples=5_000, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


@pytest.fixture(autouse=True, scope="session")
def _private_cache_dir(tmp_path_factory):
    """Decoded-trial cache in a temporary folder, not the user's ~/.cache."""
    old = os.environ.get("EVTRIBO_CACHE_DIR")
    os.environ["EVTRIBO_CACHE_DIR"] = str(tmp_path_factory.mktemp("evtribo-cache"))
    yield
    if old is None:
        os.environ.pop("EVTRIBO_CACHE_DIR", None)
    else:
        os.environ["EVTRIBO_CACHE_DIR"] = old
