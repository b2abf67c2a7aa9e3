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


@pytest.fixture
def empty_pictures(monkeypatch):
    """Every figure a command saves through ``images.save`` written as an empty file at
    the path it would have: for tests of what a command computes, writes beside its
    figures and says, whose pictures other tests hold (drawing and encoding them is most
    of such a command's time)."""
    from cardan_forces.experiments import images

    def empty(fig, stem, formats=("png",)):
        paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
        for path in paths:
            path.write_bytes(b"")
        return paths

    monkeypatch.setattr(images, "save", empty)


def variant(**overrides):
    """The paper scene with top-level keys replaced (tables merge key by key)."""
    return scene_from_dict({"extends": "paper", **overrides}, source="<variant>")
