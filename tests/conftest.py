import copy

import pytest
from cardan_forces.driveline.loading import builtin_text, load_scene, scene_from_dict
from hypothesis import settings

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib


# Every property test is derandomized: the same examples on every run and machine.
settings.register_profile("derandomized", derandomize=True, deadline=None)
settings.load_profile("derandomized")


@pytest.fixture(scope="session")
def paper():
    return load_scene("paper")


@pytest.fixture
def paper_raw():
    """The paper scene as a mutable dict, for building variants."""
    return copy.deepcopy(tomllib.loads(builtin_text("paper")))


def variant(**overrides):
    """The paper scene with top-level keys replaced (tables merge key by key)."""
    return scene_from_dict({"extends": "paper", **overrides}, source="<variant>")
