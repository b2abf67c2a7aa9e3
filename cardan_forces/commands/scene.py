"""``cardan scene``: list the built-in scenes, show, dump or check one."""

from __future__ import annotations

from pathlib import Path

from cardan_forces.driveline.elements.bearing import BearingKind
from cardan_forces.driveline.elements.registry import scene_elements
from cardan_forces.driveline.loading import builtin_names, builtin_text, load_scene


def add_parser(subparsers) -> None:
    """Register ``cardan scene {list,show,dump,check}``."""
    sc = subparsers.add_parser("scene", help="list, show, dump or check scenes")
    sc_sub = sc.add_subparsers(dest="action", required=True)
    sc_sub.add_parser("list", help="built-in scenes")
    for action, text in (("show", "a scene's contents"), ("dump", "a scene's TOML text"),
                         ("check", "validate a scene file")):
        a = sc_sub.add_parser(action, help=text)
        a.add_argument("name", help="built-in name or TOML path")
    sc.set_defaults(func=run)


def run(args) -> int:
    if args.action == "list":
        for name in builtin_names():
            print(f"{name:20s} {load_scene(name).description}")
    elif args.action == "dump":
        load_scene(args.name)  # a file that is no scene (binary, a folder): a clear error
        print(builtin_text(args.name) if args.name in builtin_names()
              else Path(args.name).read_text(encoding="utf-8-sig"), end="")
    else:
        scene = load_scene(args.name)
        if args.action == "check":
            print(f"{scene.source}: ok ({len(scene.shafts)} shafts, {len(scene.joints)} joints, "
                  f"{len(scene.time.instants())} instants, effects: "
                  f"{', '.join(sorted(scene.effects))})")
        else:
            show(scene)
    return 0


def show(scene) -> None:
    """What ``scene`` holds, one line per element, units stated."""
    print(f"scene {scene.name}: {scene.description}")
    print(f"  source       {scene.source}")
    print(f"  effects      {', '.join(sorted(scene.effects))}")
    print(f"  arrangement  {scene.arrangement}, gravity {scene.gravity_m_s2} m/s^2")
    for s in scene.shafts:
        bearings = ", ".join(f"{b.name} @ {b.offset_m:+g} m ({b.kind})"
                             for b in s.bearings) or "none"
        print(f"  shaft {s.name:13s} L={s.length_m} m  m={s.mass_kg} kg  "
              f"J={s.inertia_kg_m2} kg m^2  bearings: {bearings}")
    for kind, element, _, _ in scene_elements(scene):
        if not isinstance(kind, BearingKind):
            print(f"  {kind.describe(element)}")
    tq = scene.input_torque
    print(f"  input torque {tq.mean_N_m:+g} {tq.amplitude_N_m:+g} cos(2 pi {tq.frequency_hz:g} t"
          f" + {tq.phase_rad:g}) N m")
    g = scene.time
    print(f"  time         {g.start_s} .. {g.stop_s} s every {g.step_s} s "
          f"({len(g.instants())} instants)")
