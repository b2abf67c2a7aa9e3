"""A scene message names the key the file holds: over every key of every element table
(a bearing's, its rating's, a joint's, a slip joint's, the tolerances'), a key
misspelled (its case changed, one letter changed) is refused naming the key as
written, and a required key left out is refused naming it as missing, never another
key of the table (a valid one not yet read)."""

import copy

import pytest
from cardan_forces.driveline.loading import builtin_text, scene_from_dict
from cardan_forces.driveline.scene import SceneError

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

TABLES = {
    "rating": ("axle-pinion", ("shafts", 2, "bearings", 0, "rating")),
    "angular-contact bearing": ("axle-pinion", ("shafts", 2, "bearings", 0)),
    "locating bearing": ("paper", ("shafts", 0, "bearings", 0)),
    "joint": ("paper", ("joints", 0)),
    "slip joint": ("paper-slip", ("slip_joints", 0)),
    "tolerances": ("paper", ("tolerances",)),
}
"""Each table: the built-in scene that has it with every key it may hold (the tapered
roller rating gives ``X``, ``Y``, ``e`` and its contact angle) and where it is."""


def _raw(scene: str) -> dict:
    raw = tomllib.loads(builtin_text(scene))
    if scene == "paper":  # every key of a locating bearing's table
        raw["shafts"][0]["bearings"][0]["kind"] = "locating"
    return raw


def _table(raw: dict, where: tuple) -> dict:
    for step in where:
        raw = raw[step]
    return raw


def _path(where: tuple) -> str:
    return "".join(f"[{s}]" if isinstance(s, int) else f".{s}" for s in where).lstrip(".")


CASES = [(table, key) for table, (scene, where) in TABLES.items()
         for key in _table(_raw(scene), where)]


def _one_letter(key: str, known) -> str:
    """``key`` with its last letter changed to one that makes no known key."""
    k = max(i for i, c in enumerate(key) if c.isalpha())
    return next(key[:k] + c + key[k + 1:] for c in "qzj" if key[:k] + c + key[k + 1:]
                not in known and c != key[k])


def _refusal(table: str, change) -> str:
    scene, where = TABLES[table]
    raw = copy.deepcopy(_raw(scene))
    change(_table(raw, where))
    try:
        scene_from_dict(raw, "s.toml")
    except SceneError as err:
        return str(err)
    return ""


def test_every_table_is_covered():
    assert {"C_N", "C0_N", "X", "Y", "e", "type", "contact_angle_deg"} <= \
        {key for table, key in CASES if table == "rating"}
    assert {"contact_angle_deg", "pushes", "kind", "rating"} <= \
        {key for table, key in CASES if table == "angular-contact bearing"}
    assert len(CASES) >= 30


@pytest.mark.parametrize("table, key", CASES)
@pytest.mark.parametrize("how", ["case", "letter"])
def test_a_misspelled_key_is_named_as_written(table, key, how):
    scene, where = TABLES[table]
    known = set(_table(_raw(scene), where))
    typo = key[0].swapcase() + key[1:] if how == "case" else _one_letter(key, known)
    assert typo not in known

    def misspell(t):
        t[typo] = t.pop(key)

    message = _refusal(table, misspell)
    assert f"field '{_path(where)}.{typo}': unknown key" in message, message
    if how == "case":
        assert f"unknown key '{typo}' in {_path(where)}; did you mean '{key}'?" in message


@pytest.mark.parametrize("table, key", CASES)
def test_a_key_left_out_is_missing_or_has_a_default(table, key):
    """Left out, a key either has a default (the scene loads) or is named as missing;
    a bearing's ``kind`` left out makes it locating, whose table refuses the keys of
    its former kind by their names."""
    message = _refusal(table, lambda t: t.pop(key))
    _, where = TABLES[table]
    if table == "angular-contact bearing" and key == "kind":
        assert f"field '{_path(where)}.contact_angle_deg': unknown key" in message
    elif message:
        assert f"field '{_path(where)}.{key}': missing" in message, message


@pytest.mark.parametrize("key", ["C_N", "C0_N", "type", "contact_angle_deg", "X", "Y", "e"])
def test_each_required_rating_key_left_out_is_named(key):
    """Of a tapered roller bearing's rating every key is required (its factors as a
    set of three): none is reported as another."""
    message = _refusal("rating", lambda t: t.pop(key))
    assert f"rating.{key}': missing" in message, message


def test_a_lower_case_factor_of_an_angular_bearing_is_named():
    """``y = 1.6`` for ``Y``: the key written, not the rule on the three factors."""
    message = _refusal("rating", lambda t: t.update(y=t.pop("Y")))
    assert "unknown key 'y' in shafts[2].bearings[0].rating; did you mean 'Y'?" in message
    assert "together" not in message
