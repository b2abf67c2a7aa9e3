"""The reference pages' generated parts: every command from the ``cardan`` parser, every
scene field from the scene model, every public name from ``cardan_forces.__all__``, and
the Benchmarks page from ``docs/data/bench.json``.

Nothing here is copied by hand: each function reads the package (or the stored run) and
returns Markdown, which ``docs/hooks.py`` puts in place of a page's placeholder when the
site is built, and which ``tests/test_docs.py`` reads to check that the reference is
complete.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import json
import os
import re
import types
import typing
from pathlib import Path

from cardan_forces.driveline import loading, scene
from cardan_forces.experiments.bench_report import solved_sentence

import cardan_forces as cf
from cardan_forces import cli

BENCH_DATA = Path(__file__).parent / "data" / "bench.json"

UNITS = (("_mm2_s", "mm²/s"), ("_rpm", "r/min"), ("_kg_m2", "kg m²"), ("_kg_m3", "kg/m³"),
         ("_m_s2", "m/s²"), ("_rad_s", "rad/s"),
         ("_N_m", "N m"), ("_Pa", "Pa"), ("_hz", "Hz"), ("_deg", "deg"), ("_rad", "rad"),
         ("_kg", "kg"), ("_N", "N"), ("_s", "s"), ("_m", "m"))
"""A field's unit from the suffix of its name (SI, the package's convention)."""


# ------------------------------------------------------------------------------ CLI


def _subparsers(parser: argparse.ArgumentParser):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            yield from action.choices.items()


def commands() -> list[tuple[str, argparse.ArgumentParser]]:
    """Every command and sub-command of ``cardan`` as ``(name, parser)``, in help order."""
    found = []

    def walk(prefix: str, parser: argparse.ArgumentParser) -> None:
        for name, sub in _subparsers(parser):
            found.append((f"{prefix} {name}", sub))
            walk(f"{prefix} {name}", sub)

    walk("cardan", cli._parser())
    return found


def cli_markdown() -> str:
    """Every command's ``--help``, as the parser prints it, one section each."""
    os.environ["COLUMNS"] = "88"  # argparse wraps to the terminal: one width for the page
    top = cli._parser()
    parts = ["## cardan", "", "```text", top.format_help().rstrip(), "```", ""]
    for name, parser in commands():
        parts += [f"## {name}", "", "```text", parser.format_help().rstrip(), "```", ""]
    return "\n".join(parts)


# ---------------------------------------------------------------------------- scene


def _record_reads() -> dict[tuple[str, str], dict]:
    """Every key the loader reads, as ``(table, key) -> {"kind", "defaults"}``: the kind
    of quantity (a key of ``LIMITS``) a number is read as, and the default the loader
    gives a key a file leaves out ("required" where there is none, "optional" where a
    table loaded without it); found by loading
    every built-in scene through the loader with its readers watched. ``table`` is the
    key's table in the file, array indices dropped (``shafts[].bearings[]``).
    """
    reads: dict[tuple[str, str], dict] = {}
    table = loading._Table
    get, number, vector = table.get, table.number, table.vector

    seen: dict[str, set[int]] = {}  # the tables read at each place, by identity

    def entry(self, key) -> dict:
        where = re.sub(r"\[\d+\]", "[]", self.path) or "(top level)"
        seen.setdefault(where, set()).add(id(self))
        read = reads.setdefault((where, key), {"kind": None, "defaults": set(), "in": set()})
        read["in"].add(id(self))
        return read

    def watched_get(self, key, default=...):
        if isinstance(default, dict):  # a table whose keys have defaults of their own
            entry(self, key)["defaults"].add("optional")
        elif default is not ...:
            entry(self, key)["defaults"].add(f"`{default!r}`")
        else:
            entry(self, key)
        return get(self, key, default)

    def watched_number(self, key, *args, kind="number", within=None, **kw):
        read = entry(self, key)
        read["kind"] = kind
        if within is not None:  # a radial rating's angle (0) is read without its range
            read["within"] = within
        return number(self, key, *args, kind=kind, within=within, **kw)

    def watched_vector(self, key, size, *args, kind="position_m", unit=False, **kw):
        entry(self, key)["kind"] = "direction" if unit else kind
        return vector(self, key, size, *args, kind=kind, unit=unit, **kw)

    table.get, table.number, table.vector = watched_get, watched_number, watched_vector
    try:
        for name in loading.builtin_names():
            loading.load_scene(name)
    finally:
        table.get, table.number, table.vector = get, number, vector
    for (where, _), read in reads.items():  # a table that loaded without the key
        if not read["defaults"]:
            read["defaults"].add("optional" if read["in"] < seen[where] else "required")
    return reads


def _by_key(reads: dict) -> tuple[dict[str, str], dict[str, set[str]]]:
    """The kinds and the defaults of :func:`_record_reads` by key alone (every table)."""
    kinds: dict[str, str] = {}
    defaults: dict[str, set[str]] = {}
    for (_, key), read in reads.items():
        if read["kind"]:
            kinds.setdefault(key, read["kind"])
        defaults.setdefault(key, set()).update(read["defaults"])
    return kinds, defaults


def _read_as(read: dict):
    """How the loader reads a key: within its physical range (a
    :class:`~cardan_forces.driveline.scene.Range`) where it has one, else as its kind.
    """
    return read.get("within") or read["kind"]


def _kinds_of(cls: type, reads: dict, kinds: dict) -> dict:
    """:func:`_read_as` of each field of ``cls``, from the file's table that reads most
    of them (``joints[]`` for a joint, ``tolerances`` for the tolerances, whose
    ``articulation_deg`` differ), the other fields' kinds by key alone (``kinds``).
    """
    names = {f.name for f in dataclasses.fields(cls)}
    counts: dict[str, int] = {}
    for where, key in reads:
        counts[where] = counts.get(where, 0) + (key in names)
    table = max(counts, key=counts.get, default=None)
    return kinds | {key: _read_as(read) for (where, key), read in reads.items()
                    if where == table and key in names and _read_as(read)}


def file_keys_markdown(reads: dict) -> str:
    """Every key of a scene file the loader reads, by table, with unit, default, limit."""
    optional = {f.name for cls in scene_classes() for f in dataclasses.fields(cls)
                if f.default is not dataclasses.MISSING
                or f.default_factory is not dataclasses.MISSING}  # the model's defaults

    def default(key: str, read: dict) -> str:
        if read["defaults"] == {"required"} and key in optional:
            return "optional"
        return " or ".join(sorted(read["defaults"]))

    rows = [[f"`{where}`", f"`{key}`", _unit(key), default(key, read),
             _limit(key, {key: _read_as(read)})]
            for (where, key), read in sorted(reads.items())]
    return "\n".join(_table(["table", "key", "unit", "default", "limit"], rows)) + "\n"


def _unit(name: str) -> str:
    return next((unit for suffix, unit in UNITS if name.endswith(suffix)), "-")


def _limit(name: str, kinds: dict) -> str:
    """The limit of field ``name`` whose kind of quantity ``kinds`` gives: its physical
    range where the loader reads it within one (a :class:`~.scene.Range`, the loader's
    own constant), else its kind's :data:`~.scene.LIMITS`.
    """
    kind = kinds.get(name)
    if isinstance(kind, scene.Range):
        return str(kind)
    if kind == "direction":
        return "any length above 0 (normalized)"
    if kind not in scene.LIMITS:
        return "-"
    least, most = scene.LIMITS[kind]
    return f"\\|x\\| <= {most:g}" + (f"; >= {least:g} where positive" if least else "")


def _inner(hint) -> list[type]:
    """Dataclasses inside a type hint (``tuple[Shaft, ...]``, ``BearingRating | None``)."""
    if dataclasses.is_dataclass(hint):
        return [hint]
    return [c for arg in typing.get_args(hint) for c in _inner(arg)]


def scene_classes() -> list[type]:
    """The scene model's dataclasses, from :class:`Scene` down, then each element kind's
    record (the records of :attr:`Scene.elements` and of the joint kinds), each once.
    """
    from cardan_forces.driveline.elements.registry import KINDS

    found: list[type] = []

    def walk(cls: type) -> None:
        if cls in found:
            return
        found.append(cls)
        for hint in typing.get_type_hints(cls, vars(scene)).values():
            for inner in _inner(hint):
                walk(inner)

    walk(scene.Scene)
    for kind in KINDS:
        if dataclasses.is_dataclass(getattr(kind, "record", None)):
            walk(kind.record)
    return found


def _type_name(hint) -> str:
    if isinstance(hint, type) and not typing.get_args(hint):
        return hint.__name__
    if isinstance(hint, types.UnionType) or typing.get_origin(hint) is typing.Union:
        return " \\| ".join(_type_name(a) for a in typing.get_args(hint))
    return str(hint).replace("cardan_forces.driveline.scene.", "").replace("typing.", "")


def _default(field: dataclasses.Field, defaults: dict[str, set[str]]) -> str:
    """The loader's default where every table reads the field alike, else the model's."""
    loader = defaults.get(field.name, set())
    if len(loader) == 1 and not loader <= {"required", "optional"}:
        return next(iter(loader))
    if field.default is not dataclasses.MISSING:
        return f"`{field.default!r}`"
    if field.default_factory is not dataclasses.MISSING:
        return f"`{field.default_factory()!r}`"
    return "required"


def scene_fields() -> list[tuple[str, str]]:
    """Every field of the scene model as ``(class, field)``."""
    return [(cls.__name__, f.name) for cls in scene_classes() for f in dataclasses.fields(cls)]


def _constants() -> list[tuple[str, str, str]]:
    """The scene model's module constants with the docstring below each (``MAX_*``...)."""
    tree = ast.parse(inspect.getsource(scene))
    out = []
    for node, after in zip(tree.body, tree.body[1:]):
        if (isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name)
                and node.targets[0].id.isupper() and node.targets[0].id != "LIMITS"
                and isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant)):
            name = node.targets[0].id
            value = getattr(scene, name)
            shown = value.pattern if hasattr(value, "pattern") else value
            out.append((name, repr(shown), " ".join(after.value.value.split())))
    return out


def scene_markdown() -> str:
    """Each class of the scene model: its fields with type, unit, default and limit;
    then the limits per kind of quantity and the model's other bounds.
    """
    reads = _record_reads()
    kinds, defaults = _by_key(reads)
    parts = []
    for cls in scene_classes():
        hints = typing.get_type_hints(cls, vars(scene))
        fields = _kinds_of(cls, reads, kinds)
        doc = " ".join(inspect.getdoc(cls).split("\n\n")[0].split())
        parts += [f"### {cls.__name__}", "", doc, "",
                  "| field | type | unit | default | limit |", "|---|---|---|---|---|"]
        for f in dataclasses.fields(cls):
            parts.append(f"| `{f.name}` | {_type_name(hints[f.name])} | {_unit(f.name)} | "
                         f"{_default(f, defaults)} | {_limit(f.name, fields)} |")
        parts.append("")
    parts += ["## Every key of a scene file", "",
              "Every key the loader reads from the built-in scenes' files, by table (an "
              "array's tables as `[]`), with the default it gives a key the file leaves "
              "out. A kind of element may read keys of its own (a bearing kind's table).",
              "", file_keys_markdown(reads)]
    parts += ["## Limits per kind of quantity", "",
              "Every number is finite; a positive field is at least `least`, every field at "
              "most `most` in magnitude (`LIMITS` in `driveline/scene.py`).", "",
              "| kind | least | most |", "|---|---|---|"]
    parts += [f"| `{k}` | {lo:g} | {hi:g} |" for k, (lo, hi) in scene.LIMITS.items()]
    parts += ["", "## Other bounds", "", "| name | value | why |", "|---|---|---|"]
    parts += [f"| `{n}` | `{v}` | {d} |" for n, v, d in _constants()]
    return "\n".join(parts) + "\n"


def scene_dump(name: str = "paper") -> str:
    """The built-in scene file, with its comments (what ``cardan scene dump`` prints)."""
    return loading.builtin_text(name)


# ------------------------------------------------------------------------------ API


def api_markdown() -> str:
    """One mkdocstrings block per public name of ``cardan_forces`` (``__all__``)."""
    parts = []
    for name in cf.__all__:
        parts += [f"::: cardan_forces.{name}", "    options:",
                  "      show_root_heading: true", "      show_root_full_path: false", ""]
    return "\n".join(parts)


# ---------------------------------------------------------------------- element kinds


def element_kind_methods() -> list[tuple[str, str, str, bool]]:
    """``(name, signature, first sentence, required)`` of each method of
    :class:`ElementKind`, in the order it defines them; ``required``: its default raises
    ``NotImplementedError`` (a kind that takes part there must write it).
    """
    from cardan_forces.driveline.elements.base import ElementKind

    out = []
    for name, member in vars(ElementKind).items():
        if name.startswith("_") or not inspect.isfunction(member):
            continue
        signature = str(inspect.signature(member)).replace("'", "")
        signature = signature.replace("(self, ", "(").replace("(self)", "()").split(" ->")[0]
        doc = " ".join((inspect.getdoc(member) or "").split())
        first = re.split(r"(?<=[a-z)])\. (?=[A-Z])", doc)[0].rstrip(".")
        out.append((name, signature, first, "NotImplementedError" in inspect.getsource(member)))
    return out


def element_kind_markdown() -> str:
    """The methods of an element kind, from ``driveline/elements/base.py``."""
    rows = [[f"`{name}{signature}`", "yes" if required else "no", doc or "-"]
            for name, signature, doc, required in element_kind_methods()]
    return "\n".join(_table(["method", "must be written", "what it gives"], rows)) + "\n"


# ---------------------------------------------------------------------- formulations


def formulations_markdown() -> str:
    """The formulation registry's records: problem classes, whether the answer is a
    physical selection, the default backends, the label figures use.
    """
    rows = [[f"`{f.name}`", ", ".join(c.__name__ for c in f.problem),
             "physical selection" if f.physical else "comparison",
             ", ".join(f"`{b}`" for b in f.backends), f.label]
            for f in cf.FORMULATIONS.values()]
    return "\n".join(_table(["formulation", "problem", "its answer is", "default backends",
                              "label in figures"], rows)) + "\n"


# --------------------------------------------------------------------------- solvers


def backends_markdown() -> str:
    """Every backend the package's adapters can provide, by adapter, with the extra that
    installs it and the adapter's own summary (from ``solvers/registry.py``'s list).
    """
    from cardan_forces.solvers import registry

    rows = []
    for module in registry.ADAPTERS:
        adapter = registry._adapter(module)
        summary = " ".join((inspect.getdoc(adapter) or "").split("\n\n")[0].split())
        names = ", ".join(f"`{n}`" + (f" (`{e}`)" if e else "")
                          for n, e in adapter.EXTRAS.items())
        rows.append([f"`solvers/{module}.py`", names, summary])
    return "\n".join(_table(["adapter", "backends (extra)", "what it is"], rows)) + "\n"


# ---------------------------------------------------------------------- determinacy

SCENES = ("paper", "paper-slip", "propshaft", "propshaft-disc", "halfshaft", "double-cardan",
          "axle-pinion", "light-truck", "transfer-output")
"""The built-in scenes the determinacy table compares; the others (``paper-fig15``,
``paper-fig15-axial``, ``paper-penalty``) are ``paper`` under another gravity or with its
joints released, of ``paper``'s rigid structure."""

TOL = 1e-8
"""A component is determinate where its row of the null-space basis is below this."""


def determinacy_rows(t: float = 0.5, scenes=SCENES) -> list[dict]:
    """Rank, nullity, named modes (each kind met in any of ``scenes``) and determinate
    components of each of ``scenes`` at ``t`` s.
    """
    rows, found = [], {}
    for name in scenes:
        motion = cf.simulate(cf.load_scene(name))
        i = int(abs(motion.t - t).argmin())
        det = cf.determinacy(cf.build_operator(motion), i)
        kinds = [m.kind for m in cf.named_modes(motion, i)]
        found.update(dict.fromkeys(kinds))
        rows.append({"scene": name, "forces": len(det.names), "rank": det.rank,
                     "nullity": len(det.names) - det.rank, "kinds": kinds,
                     "determinate": int((det.null_row_norms < TOL).sum())})
    for row in rows:  # every kind of mode met in any scene, counted in each
        kinds = row.pop("kinds")
        row["modes"] = {k: kinds.count(k) for k in found}
    return rows


def determinacy_markdown() -> str:
    """The determinacy table of the built-in scenes, computed when the site is built."""
    rows = determinacy_rows()
    body = [["force components"] + [r["forces"] for r in rows],
            ["rank"] + [r["rank"] for r in rows],
            ["nullity"] + [r["nullity"] for r in rows]]
    body += [[f"modes: {k}"] + [r["modes"][k] for r in rows] for k in rows[0]["modes"]]
    body += [["determinate components"] + [r["determinate"] for r in rows]]
    return "\n".join(_table(["at t = 0.5 s"] + [f"`{r['scene']}`" for r in rows], body)) + "\n"


# ------------------------------------------------------------------------ benchmarks


def _number(value) -> str:
    if value is None:
        return "-"
    if isinstance(value, float):
        return f"{value:,.0f}" if abs(value) >= 100 else f"{value:.3g}"
    return str(value)


def _table(header: list[str], rows: list[list]) -> list[str]:
    return (["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            + ["| " + " | ".join(_number(v) for v in row) + " |" for row in rows])


def _us(seconds) -> str:
    return "-" if seconds is None else f"{1e6 * seconds:.1f}"


def bench_markdown(path: Path = BENCH_DATA) -> str:
    """The stored run: where and when, then throughput, the best backend per formulation
    against the paper's method, and where the time of an instant goes.
    """
    data = json.loads(path.read_text())
    results = data["results"]
    parts = _table(["", ""], [["command", f"`{data['command']}`"], ["date", data["date"]],
                              ["machine", data["machine"]],
                              ["threads", data.get("threads", "not recorded")],
                              ["cardan-forces", data["cardan_forces"]],
                              ["versions", data["versions"]]])
    parts += ["", "## Throughput", "",
              "Instants per second of each formulation x backend (cold: one instant at a "
              "time; warm: warm-started from the previous instant; batched: every instant "
              "at once), the share solved, the solver's iterations per instant and its "
              "share of the time. " + solved_sentence(results["throughput"]), ""]
    rows = sorted(results["throughput"],
                  key=lambda r: (r["formulation"], -(r["instants_per_s"] or 0)))
    parts += _table(["formulation", "backend", "mode", "instants/s", "solved",
                     "iterations", "solver share"],
                    [[r["formulation"], r["solver"], r["mode"], r["instants_per_s"],
                      f"{100 * (r['success_rate'] or 0):.0f} %",
                      "-" if r.get("iterations") is None else f"{r['iterations']:.2f}",
                      "-" if r["solver_share"] is None else f"{100 * r['solver_share']:.0f} %"]
                     for r in rows])
    parts += ["", "## Best backend per formulation", "",
              "The fastest run of each formulation and its ratio to the paper's method "
              "in the same run.", ""]
    parts += _table(["formulation", "backend", "mode", "instants/s", "x paper's method"],
                    [[b["formulation"], b["solver"], b["mode"], b["instants_per_s"],
                      b["paper_ratio"]] for b in results["best"]])
    parts += ["", "## Where the time goes", "",
              "Per instant, averaged over each formulation's per-instant runs (us): "
              "converting the problem for the solver, the solver, the package's checks.", ""]
    parts += _table(["formulation", "backends", "convert us", "solver us", "checks us"],
                    [[o["formulation"], o["backends"], _us(o["convert_s"]),
                      _us(o["solver_s"]), _us(o["checks_s"])] for o in results["overhead"]])
    return "\n".join(parts) + "\n"
