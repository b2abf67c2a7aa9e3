"""Fuzzing scene loading: every generated file either loads into a valid scene or raises
:class:`SceneError`, never another exception (seeded: the conftest profile
derandomizes hypothesis).

Files come from the paper scene: values replaced at random places (wrong types,
huge, tiny, NaN and infinite numbers, integers too large for a float, keys removed),
numbers scaled by extreme factors, and random bytes spliced into the TOML text.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math

import pytest
from cardan_forces.driveline.loading import builtin_text, load_scene
from cardan_forces.driveline.scene import MAX_INSTANTS, Scene, SceneError
from hypothesis import given, settings
from hypothesis import strategies as st

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

PAPER_TEXT = builtin_text("paper")
PAPER = tomllib.loads(PAPER_TEXT)
DELETE = object()
NESTED: list = []
for _ in range(400):  # arrays nested 400 deep
    NESTED = [NESTED]


def _paths(value, prefix=()):
    """Every place in the parsed scene: a tuple of keys and list indices."""
    items = value.items() if isinstance(value, dict) else \
        enumerate(value) if isinstance(value, list) else ()
    for key, child in items:
        yield prefix + (key,)
        yield from _paths(child, prefix + (key,))


PATHS = sorted(_paths(PAPER), key=repr)

ODD = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0, -1, 1e-300, -1e-300, 1e-170, 1e30, 1e300, -1e300, 10**400,
                     -(10**400), 2**63, 5e-324]),
    st.integers(),
    st.text(max_size=6),
    st.booleans(),
    st.lists(st.floats(-1e3, 1e3), max_size=4),
    st.sampled_from([{}, [], [{}], {"kind": "harmonic"}, {"kind": "constant"}, [[1.0]],
                     {"name": "x", "offset_m": 0.0}, NESTED]),
    st.just(DELETE),
)


def _toml(value) -> str:
    """A TOML value (inline tables and arrays; keys and strings quoted as JSON, which
    TOML's basic strings read the same)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf") \
            if math.isinf(value) else repr(value)
    if isinstance(value, (int, str)):
        return json.dumps(value) if isinstance(value, str) else str(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in value.items()) + "}"


def _file(raw: dict) -> str:
    return "\n".join(f"{json.dumps(k)} = {_toml(v)}" for k, v in raw.items()) + "\n"


def _mutate(raw: dict, path: tuple, value) -> None:
    parent = raw
    for key in path[:-1]:
        try:
            parent = parent[key]
        except (KeyError, IndexError, TypeError):
            return  # an earlier mutation removed or replaced this place
    if not isinstance(parent, (dict, list)) or (isinstance(parent, list) and not (
            isinstance(path[-1], int) and path[-1] < len(parent))):
        return  # an earlier mutation replaced this place by a value of another shape
    if value is DELETE:
        if isinstance(parent, dict):
            parent.pop(path[-1], None)
        else:
            del parent[path[-1]]
    elif isinstance(parent, dict) or isinstance(path[-1], int):
        parent[path[-1]] = copy.deepcopy(value)  # never a list placed inside itself


def _assert_valid(scene: Scene) -> None:
    """A loaded scene holds finite numbers only and a time grid within the limit."""
    def numbers(value):
        if isinstance(value, float):
            yield value
        elif isinstance(value, (tuple, list, frozenset)):
            for v in value:
                yield from numbers(v)
        elif dataclasses.is_dataclass(value):
            for field in dataclasses.fields(value):
                yield from numbers(getattr(value, field.name))

    assert isinstance(scene, Scene)
    assert all(math.isfinite(v) for v in numbers(scene))
    assert 2 <= len(scene.time.instants()) <= MAX_INSTANTS


def _load(tmp_path_factory, data: bytes | str):
    path = tmp_path_factory.mktemp("fuzz") / "scene.toml"
    (path.write_bytes if isinstance(data, bytes) else path.write_text)(data)
    try:
        scene = load_scene(path)
    except SceneError as err:
        assert str(path) in str(err)
        return
    _assert_valid(scene)


@pytest.mark.slow
@settings(max_examples=400)
@given(mutations=st.lists(st.tuples(st.sampled_from(PATHS), ODD), min_size=1, max_size=4))
def test_mutated_values_load_or_raise_scene_error(tmp_path_factory, mutations):
    raw = copy.deepcopy(PAPER)
    for path, value in mutations:
        _mutate(raw, path, value)
    _load(tmp_path_factory, _file(raw))


def _numbers(raw) -> list[tuple]:
    return [p for p in PATHS if isinstance(_at(raw, p), float) and not isinstance(_at(raw, p),
                                                                                  bool)]


def _at(raw, path):
    for key in path:
        raw = raw[key]
    return raw


@pytest.mark.slow
@settings(max_examples=300)
@given(data=st.data())
def test_scaled_numbers_load_or_raise_scene_error(tmp_path_factory, data):
    raw = copy.deepcopy(PAPER)
    paths = _numbers(raw)
    for path in data.draw(st.lists(st.sampled_from(paths), min_size=1, max_size=3)):
        factor = data.draw(st.sampled_from([-1.0, 0.0, 1e-300, 1e-12, 1e-6, 1e6, 1e12, 1e300]))
        _mutate(raw, path, _at(raw, path) * factor)
    _load(tmp_path_factory, _file(raw))


@pytest.mark.slow
@settings(max_examples=300)
@given(splices=st.lists(st.tuples(st.integers(0, len(PAPER_TEXT.encode())),
                                  st.binary(min_size=1, max_size=8)), min_size=1, max_size=3))
def test_bytes_spliced_into_the_file_load_or_raise_scene_error(tmp_path_factory, splices):
    data = PAPER_TEXT.encode()
    for position, chunk in splices:
        data = data[:position] + chunk + data[position + len(chunk):]
    _load(tmp_path_factory, data)
