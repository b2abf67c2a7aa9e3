"""Loading scenes: TOML read, ``extends`` merged, every field validated, then the
structural checks, all through one :func:`validate`.

A scene argument is a built-in name (``paper``, ``paper-fig15``, ...) or a path to a
UTF-8 TOML file. A file may start from another scene with ``extends = "NAME-or-path"``
(a path relative to the extending file, resolved on the real path so that
``sub/../self.toml`` is ``self.toml``; at most :data:`MAX_EXTENDS_DEPTH` scenes in a
chain; a chain that reaches a scene already in it is refused). Merge rule: the child's
tables override the parent's key by key, recursively; a table whose ``kind`` differs
from the parent's table of the same name replaces it whole (a harmonic torque for a
constant one); arrays (``shafts``, ``joints``, ``bearings``, vectors) and scalars are
replaced whole.

Bad input raises :class:`~.scene.SceneError` naming the file, the field and the value,
before any work: types, finiteness, the physical ranges of :data:`~.scene.LIMITS` (so
that nothing overflows or integrates for ever), the size of the time grid and of the
motion over it, the elements' layout (:mod:`.elements`), the support check
(:mod:`.support`: the line must turn with exactly one degree of freedom while its
contacts hold it) and the loads a friction-bound line can carry. An element's own
fields are read and checked by its kind (:mod:`.elements`: a bearing's and a joint's
by their ``kind``, an element inside a shaft by the kind whose array of tables holds
it) through this module's table reader; nothing here names a kind.
"""

from __future__ import annotations

import dataclasses
import math
from importlib import resources
from pathlib import Path

import numpy as np

from cardan_forces.util.names import did_you_mean, nearest

from .catalogue import read_rating, read_tolerances
from .duty import read_duty_cycle
from .elements.checks import check_elements
from .elements.registry import BEARING_KINDS, IN_SHAFT_KINDS, JOINT_KINDS, kind_of
from .scene import (
    EFFECTS,
    LIMITS,
    MAX_CYCLES,
    MAX_INSTANTS,
    MAX_SHAFTS,
    NAME_PATTERN,
    Contact,
    Crosspin,
    Frame,
    Joint,
    Material,
    Range,
    Scene,
    SceneError,
    Shaft,
    TimeGrid,
    TorqueLaw,
    use_validator,
)
from .support import check_scene

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

MAX_FILE_BYTES = 10_000_000
"""Largest scene file read."""

MAX_EXTENDS_DEPTH = 32
"""Most scenes in an ``extends`` chain (the file itself included): a chain is a few
scenes deep in practice; a longer one is refused with one message, never followed
until the interpreter's recursion limit."""

# ---------------------------------------------------------------------------- loading


def builtin_names() -> list[str]:
    """Names of the scenes shipped with the package."""
    folder = resources.files("cardan_forces.driveline") / "scenes"
    return sorted(p.name[: -len(".toml")] for p in folder.iterdir() if p.name.endswith(".toml"))


def builtin_text(name: str) -> str:
    """The TOML text of a built-in scene."""
    if name not in builtin_names():
        raise SceneError(f"no built-in scene {name!r}; built-in: {', '.join(builtin_names())}")
    return (resources.files("cardan_forces.driveline") / "scenes" / f"{name}.toml").read_text()


def load_scene(spec: str | Path = "paper") -> Scene:
    """Load a scene from a built-in name or a TOML path, validated."""
    raw, source = _load_raw(str(spec), chain=())
    return validate(raw, source)


def scene_from_dict(raw: dict, source: str = "<memory>") -> Scene:
    """Validate a scene given as a TOML-like dict (``extends`` is honoured)."""
    return validate(_resolve_extends(dict(raw), source, Path("."), ()), source)


def _identity(spec: str) -> tuple[str, str, str, Path]:
    """``(key, text, source, folder)`` of a scene: the key names the scene whatever the
    path that reached it (a built-in's name, a file's resolved real path).
    """
    if spec in builtin_names():
        return f"built-in {spec}", builtin_text(spec), f"{spec} (built-in)", Path(".")
    path = Path(spec)
    text = _read_text(path)
    return str(path.resolve()), text, str(path), path.parent


def _load_raw(spec: str, chain: tuple[tuple[str, str], ...]) -> tuple[dict, str]:
    """The merged raw tables of scene ``spec``; ``chain`` holds ``(key, source)`` of the
    scenes that extend it, nearest last.
    """
    if len(chain) >= MAX_EXTENDS_DEPTH:
        raise SceneError(f"scene {chain[0][1]}: field 'extends': a chain of more than "
                         f"{MAX_EXTENDS_DEPTH} scenes; at most {MAX_EXTENDS_DEPTH}")
    key, text, source, folder = _identity(spec)
    if key in (k for k, _ in chain):
        if chain[-1][0] == key:
            raise SceneError(f"scene {source}: 'extends' loops back to itself")
        loop = " -> ".join(s for _, s in chain[[k for k, _ in chain].index(key):])
        raise SceneError(f"scene {chain[0][1]}: 'extends' loops back to a scene already in "
                         f"the chain: {loop} -> {source}")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"scene {source}: not valid TOML: {err}") from None
    except RecursionError:
        raise SceneError(f"scene {source}: not valid TOML: arrays or tables nested deeper "
                         "than the parser can follow") from None
    return _resolve_extends(raw, source, folder, chain + ((key, source),)), source


def _read_text(path: Path) -> str:
    """A scene file's text: UTF-8 (TOML's encoding; a leading byte-order mark is
    dropped), at most :data:`MAX_FILE_BYTES`.
    """
    if path.is_dir():
        raise SceneError(f"scene {path}: is a directory, not a scene file")
    if not path.is_file():
        near = "" if path.suffix else did_you_mean(path.name, builtin_names())
        listed = "" if near else f" ({', '.join(builtin_names())})"
        raise SceneError(f"scene {path}: not a built-in name{listed} and no such file{near}")
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            raise SceneError(f"scene {path}: larger than {MAX_FILE_BYTES} bytes")
        data = path.read_bytes()
    except OSError as err:
        raise SceneError(f"scene {path}: cannot be read: {err.strerror}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise SceneError(f"scene {path}: not UTF-8 text (byte 0x{data[err.start]:02x} at "
                         f"offset {err.start}); TOML files are UTF-8") from None


def _resolve_extends(raw: dict, source: str, folder: Path,
                     chain: tuple[tuple[str, str], ...]) -> dict:
    """Merge ``raw`` over the scene it ``extends`` (a built-in name or a path
    relative to the extending file).
    """
    parent = raw.pop("extends", None)
    if parent is None:
        return raw
    if not isinstance(parent, str):
        raise SceneError(f"scene {source}: field 'extends': expected a scene name or path")
    if parent not in builtin_names() and (folder / parent).exists():
        parent = str(folder / parent)
    base, _ = _load_raw(parent, chain)
    return _merge(base, raw)


def _merge(base: dict, over: dict) -> dict:
    """Tables merge key by key, unless the child's table names another ``kind`` than the
    parent's (then it replaces it); anything else (arrays included) is replaced.
    """
    out = dict(base)
    for key, value in over.items():
        parent = out.get(key)
        if isinstance(value, dict) and isinstance(parent, dict) and \
                value.get("kind", parent.get("kind")) == parent.get("kind"):
            out[key] = _merge(parent, value)
        else:
            out[key] = value
    return out


# ---------------------------------------------------------------------------- validation


def _show(value) -> str:
    """``repr(value)`` cut to 60 characters (a value may be huge or nested deep)."""
    try:
        text = repr(value)
    except RecursionError:
        text = f"a {type(value).__name__} nested too deep"
    return text if len(text) <= 60 else text[:57] + "..."


def _within(value: float, kind: str) -> bool:
    return abs(value) <= LIMITS[kind][1]


class _Table:
    """Reads typed fields from one TOML table; remembers which keys were used.

    Every accessor checks type, finiteness and the range of its kind of quantity
    (:data:`LIMITS`), so that a field is validated where it is read.
    """

    def __init__(self, raw, path: str, source: str):
        self.source, self.path = source, path
        if not isinstance(raw, dict):
            self.fail("", f"expected a table, got {type(raw).__name__} {_show(raw)}")
        self.raw, self.used, self.known = raw, set(), frozenset()

    def where(self, key: str) -> str:
        return f"{self.path}.{key}" if self.path and key else self.path or key

    def fail(self, key: str, message: str):
        raise SceneError(f"scene {self.source}: field '{self.where(key)}': {message}")

    def get(self, key: str, default=...):
        self.used.add(key)
        if key not in self.raw:
            if default is ...:
                unread = [k for k in self.raw if isinstance(k, str) and k not in self.used
                          and k not in self.known]
                self.misspelled(nearest(key, unread, cutoff=0.8, most=1), [key])
                self.fail(key, "missing")
            return default
        return self.raw[key]

    def number(self, key: str, default=..., positive=False, nonnegative=False,
               kind: str = "number", within: Range | None = None, why: str = "") -> float:
        """A finite number of ``kind`` (a key of :data:`LIMITS`): at most its ``most`` in
        magnitude; when ``positive``, at least its ``least``; inside the physical range
        ``within``, if given, refused with ``why`` it is that range (the scene reference
        shows ``within`` as the field's limit).
        """
        value = self.get(key, default)
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(key, f"expected a number, got {type(value).__name__} {_show(value)}")
        try:
            value = float(value)
        except OverflowError:
            self.fail(key, f"integer too large for a number, got {_show(value)}")
        least, most = LIMITS[kind]
        if not math.isfinite(value):
            self.fail(key, f"must be finite, got {value}")
        if positive and value <= 0:
            self.fail(key, f"must be positive, got {value}")
        if nonnegative and value < 0:
            self.fail(key, f"must not be negative, got {value}")
        if positive and value < least:
            self.fail(key, f"must be at least {least:g} (limit for {kind}), got {value:g}")
        if abs(value) > most:
            self.fail(key, f"must be at most {most:g} in magnitude (limit for {kind}), "
                           f"got {value:g}")
        if within is not None and (refusal := within.refusal(value)) is not None:
            self.fail(key, f"{refusal} ({why})" if why else refusal)
        return value

    def string(self, key: str, default=..., choices: tuple[str, ...] | None = None,
               name: bool = False) -> str:
        """A string; one of ``choices`` if given; a ``name`` matches :data:`NAME_PATTERN`."""
        value = self.get(key, default)
        if not isinstance(value, str):
            self.fail(key, f"expected a string, got {type(value).__name__} {_show(value)}")
        if choices is not None and value not in choices:
            self.fail(key, f"must be one of {', '.join(choices)}, got {_show(value)}")
        if name and not NAME_PATTERN.fullmatch(value):
            self.fail(key, f"a name is letters, digits, '_' or '-' (it becomes part of "
                           f"dotted force names), got {_show(value)}")
        return value

    def vector(self, key: str, size: int, default=..., unit=False,
               kind: str = "position_m") -> tuple[float, ...]:
        """``size`` finite numbers; a ``unit`` vector is a direction: any length above
        zero, normalized without overflow or underflow; others stay within ``kind``'s
        limit.
        """
        value = self.get(key, default)
        if (
            not isinstance(value, list)
            or len(value) != size
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) for v in value)
        ):
            self.fail(key, f"expected a list of {size} numbers, got {_show(value)}")
        try:
            vec = np.array(value, dtype=float)
        except OverflowError:
            self.fail(key, f"integer too large for a number in {_show(value)}")
        if not np.all(np.isfinite(vec)):
            self.fail(key, f"must be finite, got {_show(value)}")
        if unit:
            scale = np.abs(vec).max()
            if scale == 0:
                self.fail(key, "must not be the zero vector")
            vec = vec / scale
            vec = vec / np.linalg.norm(vec)
        elif not all(_within(v, kind) for v in vec):
            self.fail(key, f"components must be at most {LIMITS[kind][1]:g} in magnitude "
                           f"(limit for {kind}), got {_show(value)}")
        return tuple(float(v) for v in vec)

    def table(self, key: str, default=...) -> _Table:
        return _Table(self.get(key, default), self.where(key), self.source)

    def tables(self, key: str, default=...) -> list[_Table]:
        value = self.get(key, default)
        if not isinstance(value, list):
            self.fail(key, f"expected an array of tables, got {type(value).__name__} "
                           f"{_show(value)}")
        return [_Table(v, f"{self.where(key)}[{i}]", self.source) for i, v in enumerate(value)]

    def misspelled(self, unknown: list[str], near: list) -> None:
        """Fail on the first of ``unknown`` keys, naming the first of the valid keys
        ``near`` it (:func:`~.names.nearest`), if any: a typo is reported as the key
        written, not as a missing one.
        """
        if not unknown:
            return
        hint = (f" '{unknown[0]}' in {self.path or 'the scene'}; did you mean '{near[0]}'?"
                if near else "")
        also = f" (also: {', '.join(unknown[1:])})" if len(unknown) > 1 else ""
        self.fail(unknown[0], f"unknown key{hint}{also}")

    def expect(self, known) -> None:
        """Declare every key the table may hold, before any is read: a key outside
        ``known`` fails now, named as written with the known key nearest it (a typo
        first); and a known key is never taken for a typo of another, so a required key
        left out is reported missing.
        """
        self.known = frozenset(known)
        unknown = sorted((k for k in self.raw if k not in self.known), key=str)
        unknown.sort(key=lambda k: not nearest(k, self.known))
        if unknown:
            self.misspelled([str(k) for k in unknown], nearest(unknown[0], self.known))

    def done(self) -> None:
        unknown = sorted(set(self.raw) - self.used)
        self.misspelled(unknown, nearest(unknown[0], sorted(self.used)) if unknown else [])


def _torque(t: _Table) -> TorqueLaw:
    kind = t.string("kind", choices=("constant", "harmonic"))
    if kind == "constant":
        law = TorqueLaw(mean_N_m=t.number("value_N_m", kind="torque_N_m"))
    else:
        law = TorqueLaw(
            mean_N_m=t.number("mean_N_m", kind="torque_N_m"),
            amplitude_N_m=t.number("amplitude_N_m", kind="torque_N_m"),
            frequency_hz=t.number("frequency_hz", nonnegative=True, kind="frequency_hz"),
            phase_rad=t.number("phase_rad", 0.0, kind="angle_rad"),
        )
    t.done()
    return law


def _torque_field(parent: _Table, key: str, default=...) -> TorqueLaw:
    value = parent.get(key, default)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return TorqueLaw(mean_N_m=parent.number(key, kind="torque_N_m"))
    if not isinstance(value, dict):
        parent.fail(
            key,
            "expected a number (constant torque, N m) or a table "
            "{kind = 'constant' | 'harmonic', ...}",
        )
    return _torque(_Table(value, parent.where(key), parent.source))


def _inertia(t: _Table, key: str) -> tuple[float, float, float]:
    j = t.vector(key, 3, kind="inertia_kg_m2")
    if min(j) <= 0:
        t.fail(key, f"inertia must be positive definite (all principal moments > 0), got {j}")
    least = LIMITS["inertia_kg_m2"][0]
    if min(j) < least:
        t.fail(key, f"principal moments must be at least {least:g} kg m^2 (limit for "
                    f"inertia_kg_m2), got {j}")
    a, b, c = j
    if a + b < c * (1 - 1e-9) or b + c < a * (1 - 1e-9) or a + c < b * (1 - 1e-9):
        t.fail(key, f"principal moments {j} violate the triangle inequality of a rigid body")
    return j


def _shaft(t: _Table) -> Shaft:
    name = t.string("name", name=True)
    length = t.number("length_m", positive=True, kind="length_m")
    bearings = []
    for bt in t.tables("bearings", []):
        kind = bt.string("kind", "locating", choices=tuple(BEARING_KINDS))
        bt.expect(BEARING_KINDS[kind].keys)
        offset = bt.number("offset_m", kind="position_m")
        if abs(offset) > length / 2:
            bt.fail("offset_m", f"bearing lies outside the shaft (|offset| > {length / 2} m), "
                                f"got {offset:g}")
        rating = read_rating(bt.table("rating")) if "rating" in bt.raw else None
        bearings.append(BEARING_KINDS[kind].read(bt, bt.string("name", name=True), offset,
                                                 rating))
        bt.used.add("rating")
        bt.done()
    if len({b.name for b in bearings}) != len(bearings):
        t.fail("bearings", "bearing names must be unique on a shaft")
    shaft = Shaft(
        name=name,
        length_m=length,
        mass_kg=t.number("mass_kg", positive=True, kind="mass_kg"),
        inertia_kg_m2=_inertia(t, "inertia_kg_m2"),
        bearings=tuple(bearings),
    )
    t.done()
    return shaft


def _scene_name(top: _Table) -> str:
    name = top.string("name")
    if not name.strip():
        top.fail("name", "must not be empty")
    return name


def validate(raw: dict, source: str) -> Scene:
    """The one validation of a scene: its fields (:func:`_fields`), then the structure
    (elements, motion, support and loads it can carry). ``raw`` has ``extends`` resolved.
    """
    scene = _fields(raw, source)
    _check_elements(scene)
    check_scene(scene)
    return scene


def revalidate(scene: Scene) -> Scene:
    """``scene`` validated again (its fields written back as tables): the validator of
    :meth:`~.scene.Scene.with_changes`.
    """
    return validate(scene_tables(scene), scene.source)


def scene_tables(scene: Scene) -> dict:
    """A scene as the TOML-like tables :func:`validate` reads (numbers exactly as held)."""
    def law(torque: TorqueLaw) -> dict:
        return {"kind": "harmonic", **dataclasses.asdict(torque)}

    def plain(value):
        if isinstance(value, (tuple, list)):
            return [plain(v) for v in value]
        if isinstance(value, dict):
            return {k: plain(v) for k, v in value.items() if v is not None}
        return value

    return plain({
        "name": scene.name, "description": scene.description,
        "effects": sorted(scene.effects), "arrangement": scene.arrangement,
        "gravity_m_s2": scene.gravity_m_s2, "frame": dataclasses.asdict(scene.frame),
        "shafts": [dataclasses.asdict(s) for s in scene.shafts],
        "joints": [dataclasses.asdict(j) for j in scene.joints],
        **{kind.table: [dataclasses.asdict(e) for e in scene.elements if kind_of(e) is kind]
           for kind in IN_SHAFT_KINDS},
        "crosspin": dataclasses.asdict(scene.crosspin),
        "torque": {"input": law(scene.input_torque), "load": law(scene.load_torque)},
        "initial": {"angle_rad": scene.initial_angle_rad,
                    "speed_rad_s": scene.initial_speed_rad_s},
        "time": dataclasses.asdict(scene.time),
        "material": dataclasses.asdict(scene.material),
        "contact": dataclasses.asdict(scene.contact),
        "tolerances": dataclasses.asdict(scene.tolerances) if scene.tolerances else None,
        "duty_cycle": [dataclasses.asdict(b) for b in scene.duty_cycle],
    })


def _effects(top: _Table) -> list[str]:
    effects = top.get("effects", ["gravity", "inertia"])
    if not isinstance(effects, list) or not all(isinstance(e, str) for e in effects):
        top.fail("effects", "expected a list of effect names")
    for e in effects:
        if e not in EFFECTS:
            top.fail("effects", f"unknown effect {e!r}; known: {', '.join(EFFECTS)}")
    if "crosspin_inertia" in effects and "inertia" not in effects:
        top.fail("effects", "'crosspin_inertia' needs 'inertia' (a quasi-static analysis "
                 "has no d'Alembert terms)")
    if "penalty_dynamics" in effects and "inertia" not in effects:
        top.fail("effects", "'penalty_dynamics' needs 'inertia' (the penalty simulation is "
                 "dynamic; its rigid counterpart must be too)")
    return effects


def _frame(top: _Table) -> Frame:
    frame_t = top.table("frame", {})
    frame = Frame(
        input_start_m=frame_t.vector("input_start_m", 3, [0.0, 0.0, 0.0], kind="position_m"),
        input_axis=frame_t.vector("input_axis", 3, [1.0, 0.0, 0.0], unit=True),
        articulation_towards=frame_t.vector("articulation_towards", 3, [0.0, 0.0, 1.0],
                                            unit=True),
    )
    if abs(np.dot(frame.input_axis, frame.articulation_towards)) > 1 - 1e-9:
        frame_t.fail("articulation_towards", "must not be parallel to input_axis")
    frame_t.done()
    return frame


def _chain(top: _Table) -> tuple[tuple[Shaft, ...], tuple[Joint, ...], list[str]]:
    """Shafts and joints, counted and named uniquely; the names taken."""
    shaft_tables = top.tables("shafts")
    if len(shaft_tables) > MAX_SHAFTS:
        top.fail("shafts", f"at most {MAX_SHAFTS} shafts, got {len(shaft_tables)}")
    shafts = tuple(_shaft(t) for t in shaft_tables)
    joints = tuple(_joint(t) for t in top.tables("joints"))
    if len(shafts) < 2:
        top.fail("shafts", "a drive line needs at least two shafts")
    if len(joints) != len(shafts) - 1:
        top.fail("joints", f"{len(shafts)} shafts need {len(shafts) - 1} joints, got {len(joints)}")
    names = [s.name for s in shafts] + [j.name for j in joints]
    if len(set(names)) != len(names):
        top.fail("shafts", f"shaft and joint names must be unique, got {names}")
    return shafts, joints, names


def _joint(t: _Table) -> Joint:
    """A joint, read by its kind (a Cardan joint unless ``kind`` names another)."""
    return JOINT_KINDS[t.string("kind", "cardan", choices=tuple(JOINT_KINDS))].read(t)


def _in_shaft(top: _Table, shafts: tuple[Shaft, ...], names: list[str]) -> tuple:
    """The elements inside the shafts, each kind reading its own array of tables, in
    chain order (by shaft, then offset): named apart from each other and from the shafts
    and joints (``names``), no two cutting a shaft at one place.
    """
    by_name = {s.name: s for s in shafts}
    elements = [kind.read(t, by_name) for kind in IN_SHAFT_KINDS
                for t in top.tables(kind.table, [])]
    taken = list(names)
    for e in elements:
        if e.name in taken:
            top.fail(kind_of(e).table, f"{kind_of(e).noun} name {e.name!r} is taken: "
                     "names differ from each other and from shafts and joints")
        taken.append(e.name)
    cuts: dict[tuple[str, float], str] = {}
    for e in (e for e in elements if kind_of(e).cuts):
        if (e.shaft, e.offset_m) in cuts:
            top.fail(kind_of(e).table, f"{e.name!r} and {cuts[e.shaft, e.offset_m]!r} cut "
                     f"shaft {e.shaft!r} at one place ({e.offset_m:g} m)")
        cuts[e.shaft, e.offset_m] = e.name
    order = {name: k for k, name in enumerate(by_name)}
    return tuple(sorted(elements, key=lambda e: (order[e.shaft], e.offset_m)))


def _time(top: _Table) -> TimeGrid:
    tt = top.table("time")
    time = TimeGrid(tt.number("start_s", 0.0, kind="time_s"), tt.number("stop_s", kind="time_s"),
                    tt.number("step_s", positive=True, kind="step_s"))
    if time.stop_s <= time.start_s:
        tt.fail("stop_s", f"must be after start_s ({time.start_s}), got {time.stop_s}")
    if time.step_s > time.stop_s - time.start_s:
        tt.fail("step_s", f"longer than the time span {time.stop_s - time.start_s:g} s, "
                          f"got {time.step_s:g}")
    instants = round((time.stop_s - time.start_s) / time.step_s) + 1
    if instants > MAX_INSTANTS:
        tt.fail("step_s", f"gives {instants:.3g} instants from {time.start_s:g} to "
                          f"{time.stop_s:g} s; at most {MAX_INSTANTS}")
    tt.done()
    return time


def _material(top: _Table) -> Material:
    mt = top.table("material", {})
    material = Material(
        youngs_modulus_Pa=mt.number("youngs_modulus_Pa", 2.07e11, positive=True,
                                    kind="pressure_Pa"),
        poisson_ratio=mt.number("poisson_ratio", 0.29),
        density_kg_m3=mt.number("density_kg_m3", 7850.0, positive=True, kind="density_kg_m3"),
    )
    if not -1.0 < material.poisson_ratio < 0.5:
        mt.fail("poisson_ratio", f"must lie in (-1, 0.5), got {material.poisson_ratio}")
    mt.done()
    return material


def _contact(top: _Table, effects: list[str]) -> Contact:
    ct = top.table("contact", {})
    contact = Contact(
        exponent=ct.number("exponent", 1.5, positive=True, kind="ratio"),
        damping_full_depth_m=ct.number("damping_full_depth_m", 1e-5, positive=True,
                                       kind="length_m"),
        damping_fraction_of_stiffness=ct.number("damping_fraction_of_stiffness", 0.01,
                                                nonnegative=True, kind="ratio"),
        bearing_clearance_m=ct.number("bearing_clearance_m", 1e-5, nonnegative=True,
                                      kind="position_m"),
        bearing_stiffness_N_m=ct.number("bearing_stiffness_N_m", 1e9, positive=True,
                                        kind="stiffness"),
        friction_coefficient=ct.number("friction_coefficient", 0.0, nonnegative=True,
                                          kind="ratio"),
    )
    if "friction" in effects and contact.friction_coefficient <= 0:
        ct.fail("friction_coefficient", "the 'friction' effect needs a positive coefficient")
    ct.done()
    return contact


def _fields(raw: dict, source: str) -> Scene:
    """Every field of the scene, read and checked table by table."""
    top = _Table(raw, "", source)
    effects = _effects(top)
    frame = _frame(top)
    shafts, joints, names = _chain(top)
    cp = top.table("crosspin", {"mass_kg": 0.05, "inertia_kg_m2": [1e-5, 1e-5, 2e-5]})
    crosspin = Crosspin(mass_kg=cp.number("mass_kg", positive=True, kind="mass_kg"),
                        inertia_kg_m2=_inertia(cp, "inertia_kg_m2"))
    cp.done()
    torque = top.table("torque")
    input_torque = _torque_field(torque, "input")
    load_torque = _torque_field(torque, "load", 0.0)
    torque.done()
    init = top.table("initial", {})
    initial = (init.number("angle_rad", 0.0, kind="angle_rad"),
               init.number("speed_rad_s", 0.0, kind="speed_rad_s"))
    init.done()
    time = _time(top)
    material, contact = _material(top), _contact(top, effects)
    elements = _in_shaft(top, shafts, names)
    scene = Scene(
        name=_scene_name(top), description=top.string("description", ""),
        effects=frozenset(effects), arrangement=top.string("arrangement", "Z", choices=("Z", "W")),
        gravity_m_s2=top.vector("gravity_m_s2", 3, [0.0, 0.0, -9.81], kind="gravity_m_s2"),
        frame=frame, shafts=shafts, joints=joints, crosspin=crosspin,
        input_torque=input_torque, load_torque=load_torque,
        initial_angle_rad=initial[0], initial_speed_rad_s=initial[1],
        time=time, material=material, contact=contact, source=source, elements=elements,
        tolerances=read_tolerances(top), duty_cycle=read_duty_cycle(top))
    top.done()
    for key, law in (("input", scene.input_torque), ("load", scene.load_torque)):
        periods = law.frequency_hz * (time.stop_s - time.start_s)
        if periods > MAX_CYCLES:
            torque.fail(key, f"{law.frequency_hz:g} Hz over the time span is {periods:.3g} "
                             f"periods; at most {MAX_CYCLES:g}")
    return scene


def _check_elements(scene: Scene) -> None:
    """Each element's kind's checks, then parts of the line left unheld by elements inside
    shafts or bearings a shaft slides through (a message more specific than the support
    check's).
    """
    check_elements(scene, sliding=bool(scene.elements) or any(
        BEARING_KINDS[b.kind].slides for s in scene.shafts for b in s.bearings))


use_validator(revalidate)
