"""The paper's own method as a problem: 34 polar unknowns, 34 nonlinear equations.

The root finding (``fsolve``, ``root(lm)``, multistart) goes through the solver
registry like every other solve: ``cardan_forces.experiments.paper_method``.

Wang & Qi (2017) write every radial contact force as a magnitude and a contact angle
(bearings eqs. 11-14, trunnions eqs. 37, 44), keep the end-face forces as magnitudes
(eqs. 38, 45) whose contact points sit on the trunnion rim at angles fixed by the
radial ones (eqs. 33-36, 42-43), merge the two axial bearing forces of a shaft into
one unknown, and solve the Newton-Euler rows (eqs. 49-58) together with the
Fischer-Burmeister form of the end-face complementarity (eqs. 59-62).

Unknowns ``z`` (``unknown_names``), per shaft with bearings, in scene order: each
bearing's radial magnitude and angle, then the shaft's axial sum; per joint:
``theta1, theta2, theta5, theta6, f1, ..., f8``. Signs (derived, the OCR lost them):

- bearing: force on the shaft ``f (cos a u + sin a w) + g/n s`` with ``s`` the shaft
  axis (downstream), ``u`` the unit part of the frame's ``articulation_towards``
  normal to ``s`` (the paper's ``i3``), ``w = s x u`` (``i1``). The paper's frame turns
  with the shaft; the bearing is axisymmetric, so a fixed frame only shifts the angle.
  The merged axial force ``g`` is split evenly between the ``n`` bearings: the split
  lies in the null space of ``A`` and changes no equation.
- trunnion ``+hs e1``: contact at ``hs e1 + rs (cos t1 e2 + sin t1 e3)``, force on the
  pin ``-f1 (cos t1 e2 + sin t1 e3)``; driven ``+hs e2``: contact at
  ``hs e2 + rs (sin t5 e1 + cos t5 e3)``, force ``-f5 (sin t5 e1 + cos t5 e3)``.
- end faces (eqs. 33-36): minimizing the axial gap over the rim gives
  ``(c3, s3) = S (-sin m, cos m)``, ``(c4, s4) = -(c3, s3)``, ``m = (t1 + t2)/2``,
  ``S = Sgn(sin((t2 - t1)/2))``; driven side (eqs. 42-43) ``(c7, s7)`` the same in
  ``t5, t6`` with the rim point ``rt (s7 e1 + c7 e3)``. F3 pushes along ``-e1`` at
  ``ht e1 + rt (c3 e2 + s3 e3)``, F4 along ``+e1`` at the opposite rim point, so the
  pair adds the moment ``-(f3 + f4) rt S (cos m e2 + sin m e3)`` on the pin (the
  driven pair ``-(f7 + f8) rt S (sin m e1 + cos m e3)``) and the opposite on the
  yoke's shaft. The package's operator puts end-face forces on the axis; ``rim=False``
  drops these moments and then the paper's equations are exactly ``A x = b``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.kinematics import rest_geometry
from cardan_forces.driveline.scene import Scene

from cardan_forces.util.rank import RANK_RTOL

from .convex import NotApplicable, socp_face
from .problems import NLS, SCALE_FLOOR_N, ForceChecks, LastMade

TINY = 1e-12
"""Relative magnitude under which a start's contact angle is set to 0."""

_FB_ORIGIN = 1.0 / np.sqrt(2.0) - 1.0
"""Generalized derivative of ``sqrt(a^2 + b^2) - a - b`` at (0, 0) in a and b."""


def end_faces_words(rim: bool) -> str:
    """Where the paper's method, as built with ``rim`` (:func:`build_paper`), puts the
    end-face forces, in the words every output uses: at the rim (eqs. 33-36, the
    ``paper`` formulation of the figures), or on the axis as the package's operator
    does (the rim moments dropped, the equations exactly ``A x = b``).
    """
    if rim:
        return "end faces at the rim, eqs. 33-36"
    return "end faces on the axis, without the rim moments of eqs. 33-36"


@dataclass(frozen=True)
class PaperNLS(NLS):
    """The paper's 34 x 34 system plus its own residual and unknown names."""

    unknown_names: tuple[str, ...] = ()
    paper_residual: object = field(default=None, repr=False)
    rim: bool = True
    radial: np.ndarray = field(default=None, repr=False)
    angles: np.ndarray = field(default=None, repr=False)
    end_faces: np.ndarray = field(default=None, repr=False)

    def canonical(self, z: np.ndarray) -> tuple[np.ndarray, bool]:
        """The same polar point with nonnegative radial magnitudes (``(-f, a) -> (f, a +
        pi)``) and angles in (-pi, pi]; and whether any magnitude flipped. A change of
        variables: without the rim it changes no force, with it the end-face rim points
        (eqs. 33-36, 42-43) move, since they depend on the angles.
        """
        z = np.array(z, float)
        neg = z[self.radial] < 0
        z[self.radial[neg]] *= -1.0
        z[self.angles[neg]] += np.pi
        z[self.angles] = np.pi - np.mod(np.pi - z[self.angles], 2.0 * np.pi)
        return z, bool(neg.any())


@dataclass(frozen=True)
class _Layout:
    """Where each polar unknown goes in ``x`` (36) and in the rows (30)."""

    P: np.ndarray  # (n_x, n_polar): x += f cos(a) P[:, p] + f sin(a) Q[:, p]
    Q: np.ndarray
    mag: np.ndarray  # (n_polar,) index into z of f
    ang: np.ndarray  # (n_polar,) index into z of a
    L: np.ndarray  # (n_x, n_z): linear part (axial sums, end faces)
    rim_U: np.ndarray  # (n_rows, n_sides): rim moment direction for cos m
    rim_V: np.ndarray  # (n_rows, n_sides): for sin m
    rim_t: np.ndarray  # (n_sides, 2) z indices of the two radial angles
    rim_f: np.ndarray  # (n_sides, 2) z indices of the two end-face forces
    rim_r: np.ndarray  # (n_sides,) rim radius rt
    fb: np.ndarray  # (n_pairs, 2) z indices of the complementary magnitudes
    names: tuple[str, ...]


def _layout(op: Operator, i: int, scene: Scene) -> _Layout:
    """Map the polar unknowns onto the operator's columns and rows at instant ``i``: the
    structure (the same at every instant, made once per operator and scene) with the
    rim moments' directions of the cross-pin frames at ``i``.
    """
    lay, (sides, joint, cos_at, sin_at) = _structure(op, scene)
    frames = op.pin_frames[joint, i]  # (sides, 3 axes, 3)
    rows = np.arange(len(joint))
    return dataclasses.replace(
        lay, rim_U=np.einsum("srk,sk->rs", sides, frames[rows, cos_at]),
        rim_V=np.einsum("srk,sk->rs", sides, frames[rows, sin_at]))


@LastMade
def _structure(op: Operator, scene: Scene) -> tuple[_Layout, tuple]:
    """The polar unknowns on the operator's columns and rows, with the rim moments'
    directions left out (``rim_U``, ``rim_V`` empty) and what gives them at an
    instant: per side, the signed selection of its pin's and yoke's force rows
    (sides, rows, 3), its joint, and which pin-frame axes are its cosine and sine
    directions.
    """
    names, A = op.names, op.A[0]
    geo = rest_geometry(scene)
    towards = np.array(scene.frame.articulation_towards, float)
    z_names: list[str] = []
    P_cols, Q_cols, mag, ang, lin = [], [], [], [], []

    def unit(col: int) -> np.ndarray:
        return np.eye(len(names))[col]

    def add(name: str) -> int:
        z_names.append(name)
        return len(z_names) - 1

    for k, shaft in enumerate(scene.shafts):
        if not shaft.bearings:
            continue
        s = geo.axes[k]
        u = towards - towards.dot(s) * s
        u /= np.linalg.norm(u)
        w = np.cross(s, u)
        axial = np.zeros(len(names))
        for bearing in shaft.bearings:
            link = next(c for c in op.bearings(k) if c.label == bearing.name)
            cols = [link.column(c) for c in "xyz"]
            p, q = np.zeros(len(names)), np.zeros(len(names))
            p[cols], q[cols], axial[cols] = u, w, s / len(shaft.bearings)
            P_cols.append(p)
            Q_cols.append(q)
            mag.append(add(f"{shaft.name}.bearing.{bearing.name}.radial"))
            ang.append(add(f"{shaft.name}.bearing.{bearing.name}.angle"))
        lin.append((add(f"{shaft.name}.axial_sum"), axial))

    n_rows = A.shape[0]
    sides, joint_of, cos_at, sin_at, rim_t, rim_f, rim_r, fb = [], [], [], [], [], [], [], []
    yokes = {(c.joint, c.trunnion): (c.body, c.other) for c in op.contacts if c.trunnion}
    for j, joint in enumerate(scene.joints):
        contact = op.joint_contacts(j)  # by the paper's labels F1 ... F8
        theta = {t: add(f"{joint.name}.theta{t}") for t in (1, 2, 5, 6)}
        f = {n: add(f"{joint.name}.f{n}") for n in range(1, 9)}
        for n, (cos_c, sin_c) in {1: ("e2", "e3"), 2: ("e2", "e3"),
                                  5: ("e3", "e1"), 6: ("e3", "e1")}.items():
            P_cols.append(-unit(contact[f"F{n}"].column(cos_c)))
            Q_cols.append(-unit(contact[f"F{n}"].column(sin_c)))
            mag.append(f[n])
            ang.append(theta[n])
        for n in (3, 4, 7, 8):
            lin.append((f[n], unit(contact[f"F{n}"].columns[0])))
        for trunnion, (ta, tb), (fa, fb_), (cos_axis, sin_axis) in (
            ("e1", (1, 2), (3, 4), (1, 2)),  # cos along e2, sin along e3
            ("e2", (5, 6), (7, 8), (2, 0)),  # cos along e3, sin along e1
        ):
            side = np.zeros((n_rows, 3))
            pin, yoke = yokes[(j, trunnion)]
            for body, sign in ((pin, 1.0), (yoke, -1.0)):
                moment = op.body_rows(body)
                side[np.arange(moment.start, moment.stop), np.arange(3)] += sign
            sides.append(side)
            joint_of.append(j)
            cos_at.append(cos_axis)
            sin_at.append(sin_axis)
            rim_t.append((theta[ta], theta[tb]))
            rim_f.append((f[fa], f[fb_]))
            rim_r.append(joint.rt_m)
            fb.append((f[fa], f[fb_]))

    L = np.zeros((len(names), len(z_names)))
    for idx, col in lin:
        L[:, idx] = col
    empty = np.zeros((n_rows, 0))
    lay = _Layout(
        P=np.array(P_cols).T, Q=np.array(Q_cols).T, mag=np.array(mag), ang=np.array(ang), L=L,
        rim_U=empty, rim_V=empty,
        rim_t=np.array(rim_t, int).reshape(-1, 2), rim_f=np.array(rim_f, int).reshape(-1, 2),
        rim_r=np.array(rim_r, float), fb=np.array(fb, int).reshape(-1, 2), names=tuple(z_names),
    )
    return lay, (np.array(sides).reshape(-1, n_rows, 3), np.array(joint_of, int),
                 np.array(cos_at, int), np.array(sin_at, int))


def applies(op: Operator) -> None:
    """Raise :class:`NotApplicable` unless the operator has the paper's layout: every
    bearing locating (the paper merges a shaft's axial forces into one unknown), no
    slip joint, and as many polar unknowns as equations (2 per bearing + 1 per shaft
    with bearings + 12 per joint = 6 per body + 2 per joint; 34 for the paper's line).
    """
    others = sorted({c.element_kind.words(c) for c in op.contacts if not c.element_kind.paper})
    if others:
        raise NotApplicable(
            "the paper's method (34 polar unknowns, eqs. 49-62) does not apply to scenes "
            f"with elements it does not write ({', '.join(others)}): it writes every "
            "bearing as locating and every joint as a cross-pin")
    bearings = op.bearings()
    unknowns = 2 * len(bearings) + len({c.shaft for c in bearings}) + 12 * len(op.scene.joints)
    equations = op.A.shape[1] + 2 * len(op.scene.joints)
    if unknowns != equations:
        raise NotApplicable(
            f"the paper's method does not apply to this layout: its polar unknowns "
            f"({unknowns}) and equations ({equations}) differ (it is square, 34 x 34, for "
            "the paper's 3 shafts, 2 joints and 2 bearings on each end shaft)")


@dataclass(frozen=True)
class _Terms:
    """What maps the polar unknowns to the forces at every instant of an operator: the
    layout's indices (``lay``, rim directions left out; ``take``: the unknowns the
    polar terms read, in :func:`_polar`'s order) and the forces as a product
    ``x = forces @ w[:2p + n]`` of the polar terms ``w``.
    """

    lay: _Layout
    take: np.ndarray
    neg_rt: np.ndarray  # (pairs, 1): -rt per trunnion pair
    forces: np.ndarray  # (n_x, 2p + n_z): [P, Q, L]
    rim: bool


@LastMade
def _terms(op: Operator, scene: Scene, rim: bool) -> _Terms:
    """:class:`_Terms` of ``op`` (with the rim moments or not), made once per operator."""
    lay = _structure(op, scene)[0]
    take = np.concatenate([lay.mag, lay.ang] + ([lay.rim_t.T.ravel(), lay.rim_f.T.ravel()]
                                                if rim else []))
    return _Terms(lay=lay, take=take, neg_rt=-lay.rim_r[:, None],
                  forces=np.hstack([lay.P, lay.Q, lay.L]), rim=rim)


def _polar(t: _Terms, zt: np.ndarray) -> np.ndarray:
    """The polar terms ``w = [f cos a, f sin a, z (, kf cos m, kf sin m)]`` (len(w), T)
    of the points ``zt`` (n_z, T), one per column (eqs. 11-14, 37-38, 44-45; the rim's
    eqs. 33-36, 42-43: per trunnion pair ``kf = k (f_a + f_b)``,
    ``k = -rt Sgn(sin((t_b - t_a)/2))``, ``m = (t_a + t_b)/2``).
    """
    g = zt[t.take]
    p = len(t.lay.mag)
    f, a = g[:p], g[p:2 * p]
    polar = [f * np.cos(a), f * np.sin(a), zt]
    if t.rim:
        S = len(t.neg_rt)
        ta, tb, fa, fb = (g[2 * p + q * S:2 * p + (q + 1) * S] for q in range(4))
        kf = t.neg_rt * np.sign(np.sin(0.5 * (tb - ta))) * (fa + fb)
        m = 0.5 * (ta + tb)
        polar += [kf * np.cos(m), kf * np.sin(m)]
    return np.concatenate(polar)


def _cartesian(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """Polar unknowns -> the 36 Cartesian forces (eqs. 11-14, 37-38, 44-45) in the
    residual's order of operations (its roots move with its last bits:
    :func:`build_paper`).
    """
    f, a = z[lay.mag], z[lay.ang]
    return lay.P @ (f * np.cos(a)) + lay.Q @ (f * np.sin(a)) + lay.L @ z


def _rim_moments(lay: _Layout, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """Rim moments of the end faces (eqs. 35-36, 42-43 in eqs. 50-58), with the parts
    their Jacobian reuses: ``(R, dirs, k, fsum, m)``.
    """
    t, f = z[lay.rim_t], z[lay.rim_f]
    ta, tb = t[:, 0], t[:, 1]
    fsum = f[:, 0] + f[:, 1]
    m = 0.5 * (ta + tb)
    k = -lay.rim_r * np.sign(np.sin(0.5 * (tb - ta)))
    dirs = lay.rim_U * np.cos(m) + lay.rim_V * np.sin(m)  # (rows, sides)
    return dirs @ (k * fsum), dirs, k, fsum, m


def _residual(lay: _Layout, A: np.ndarray, b: np.ndarray, rim: bool,
              z: np.ndarray) -> np.ndarray:
    """The paper's residual ``F(z)``: the Newton-Euler rows (eqs. 49-58, with the rim
    moments when ``rim``), then the Fischer-Burmeister rows (eqs. 59-62).
    """
    eq = A @ _cartesian(lay, z) - b
    if rim:
        eq = eq + _rim_moments(lay, z)[0]
    return np.concatenate([eq, _fb_rows(lay, z)])


def _jacobian(lay: _Layout, A: np.ndarray, rim: bool, z: np.ndarray) -> np.ndarray:
    """Jacobian of :func:`_residual`: ``A dx/dz`` (plus the rim moments' derivative;
    ``Sgn`` is piecewise constant, so it has none) over the Fischer-Burmeister rows'.
    """
    f, a = z[lay.mag], z[lay.ang]
    c, s = np.cos(a), np.sin(a)
    dx = lay.L.copy()
    dx[:, lay.mag] += lay.P * c + lay.Q * s
    dx[:, lay.ang] += (lay.Q * c - lay.P * s) * f
    eq = A @ dx
    if rim:
        R, dirs, k, fsum, m = _rim_moments(lay, z)
        along = dirs * k
        turn = (lay.rim_V * np.cos(m) - lay.rim_U * np.sin(m)) * (0.5 * k * fsum)
        J = np.zeros((len(R), len(z)))
        for col in (0, 1):  # a pair's two forces and two angles: distinct unknowns
            J[:, lay.rim_f[:, col]] += along
            J[:, lay.rim_t[:, col]] += turn
        eq = eq + J
    fb = np.zeros((len(lay.fb), len(z)))
    fb[np.arange(len(lay.fb))[:, None], lay.fb] = _fb_slopes(lay, z)
    return np.vstack([eq, fb])


def _fb_rows(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """Fischer-Burmeister rows (eqs. 59-62): ``sqrt(a^2 + b^2) - a - b`` per pair."""
    a, b = z[lay.fb[:, 0]], z[lay.fb[:, 1]]
    return np.hypot(a, b) - a - b


def _fb_slopes(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """The (generalized) derivatives (pairs, 2) of the Fischer-Burmeister rows
    (:func:`_fb_rows`) in their pair's two unknowns ``a, b``: ``a / r - 1``,
    ``b / r - 1`` with ``r = hypot(a, b)``, and :data:`_FB_ORIGIN` at ``r = 0``.
    """
    ab = z[lay.fb]
    r = np.hypot(ab[:, 0], ab[:, 1])[:, None]
    out, live = np.full(ab.shape, _FB_ORIGIN), r > 0
    np.divide(ab, r, out=out, where=live)
    return np.subtract(out, 1.0, out=out, where=live)


def _start(op: Operator, i: int, lay: _Layout) -> np.ndarray:
    """Initial values (eqs. 63-74): end faces zero, the rest least-norm on the axis."""
    A, b = op.A[i], op.b[i]
    keep = ~np.asarray(op.unilateral, bool)
    x = np.zeros(A.shape[1])
    x[keep] = np.linalg.lstsq(A[:, keep], b, rcond=None)[0]
    z = np.zeros(len(lay.names))
    z[lay.mag] = np.hypot(lay.P.T @ x, lay.Q.T @ x)
    tiny = z[lay.mag] <= TINY * max(np.linalg.norm(b), TINY)
    z[lay.ang] = np.where(tiny, 0.0, np.arctan2(lay.Q.T @ x, lay.P.T @ x))
    # axial sums and end faces: project x on their columns of L (end faces give 0)
    linear = np.flatnonzero(np.any(lay.L != 0, axis=0))
    cols = lay.L[:, linear]
    z[linear] = (cols.T @ x) / np.sum(cols * cols, axis=0)
    return z


def build_paper(op: Operator, i: int, name: str = "", rim: bool = True,
                scene: Scene | None = None) -> PaperNLS:
    """The paper's system (eqs. 49-62) at instant ``i`` of ``op``.

    ``scene`` (default: the operator's) supplies the shaft axes for the bearing angles
    and the rim radius ``rt``. With ``rim=True`` the answer is judged in ``socp_face``'s
    force space (forces plus end-face moments, the rim moments being such moments on
    the cone's boundary), so the package's residuals check the paper's own model;
    ``paper_residual(z)`` is ``||F(z)|| / ||b||`` of the paper's equations.

    ``fun`` and ``jac`` keep their order of operations: the system is singular at its
    roots (rank 33 of 34, the closed loop's self-stress, condition 1e17-1e18), so the
    root a solve reaches moves along that direction with the residual's last bits
    (``F (1 + 2^-52)`` moves ``fsolve``'s forces by 12 % on ``paper`` at 0 s).
    """
    scene = op.scene if scene is None else scene
    applies(op)
    lay, t = _layout(op, i, scene), _terms(op, scene, rim)
    A, b = op.A[i], op.b[i]
    scale = max(float(np.linalg.norm(b)), SCALE_FLOOR_N)

    def fun(z):
        return _residual(lay, A, b, rim, np.asarray(z, float))

    @_last_point
    def jac(z):
        return _jacobian(lay, A, rim, z)

    if rim:
        # judged in the force space of ``socp_face``: the rim moments become end-face
        # moments, which the centre-of-pressure cone ||m|| <= rt f must contain
        plan = _face_plan(op, scene)
        M = np.where(plan.sine, lay.rim_V[:, plan.side], lay.rim_U[:, plan.side])
        checks = dataclasses.replace(plan.checks, A=np.hstack([A, M]), b=b)
        to_forces = _PaperForces(t, plan, M, np.hstack([lay.rim_U, lay.rim_V]))
    else:
        checks = ForceChecks(A=A, b=b, names=op.names, unilateral=op.unilateral,
                             pairs=op.pairs)
        to_forces = _PaperForces(t)
    return PaperNLS(
        checks=checks, formulation=name, to_forces=to_forces,
        fun=fun, jac=jac, z0=_start(op, i, lay), unknown_names=lay.names,
        paper_residual=lambda z: float(np.linalg.norm(fun(z))) / scale,
        rim=rim, radial=lay.mag, angles=lay.ang, end_faces=lay.fb.ravel(),
    )


def _last_point(f):
    """``f`` (of a point ``z``) that gives again, as a copy, the value it gave last when
    called at the same point again instead of computing it: a warm-started ``fsolve``
    asks for the Jacobian at one point twice or three times an instant (scipy checks
    the start before MINPACK starts, the record's note asks at the answer).
    """
    last = [None, None]

    def at(z):
        z = np.asarray(z, float)
        key = z.tobytes()
        if key != last[0]:
            last[:] = key, f(z)
        return last[1].copy()

    return at


@dataclass(frozen=True)
class _FacePlan:
    """``socp_face``'s force space for the paper's answers, the same at every instant
    of an operator: its checks at the first instant (names, signs, pairs, cones; ``A``
    and ``b`` are replaced per instant), and per end-face moment unknown its trunnion
    pair (``side``), whether it lies along the pair's ``V`` (sine) rim direction or its
    ``U`` (cosine) one, which face owns it (``slot`` in ``faces``: the force columns of
    the two faces of pair ``s`` at ``2 s`` and ``2 s + 1``) and where its pair's rim
    term along that direction sits in the polar terms ``w`` (``rim_at``). ``split``:
    every face has one moment along ``U`` and one along ``V`` and the pairs' rim
    directions are independent, so :func:`_face_moments` has its closed form.
    """

    checks: ForceChecks
    side: np.ndarray
    sine: np.ndarray
    slot: np.ndarray
    rim_at: np.ndarray
    faces: np.ndarray
    split: bool


@LastMade
def _face_plan(op: Operator, scene: Scene) -> _FacePlan:
    """:class:`_FacePlan` of ``op``: ``socp_face``'s moment columns (the pin-frame axes
    normal to each trunnion, on the pin's rows and the opposite on the yoke's) matched
    to the rim directions ``U``, ``V`` of the paper's layout, both at the first instant.
    """
    face, lay = socp_face(op, 0).checks, _layout(op, 0, scene)
    pair_x = np.argmax(lay.L[:, lay.rim_f], axis=0).reshape(-1, 2)  # unit columns of L
    side, sine, which = [], [], []
    for cone in face.cones:
        s, f = (int(v[0]) for v in np.nonzero(pair_x == cone.apex))
        for member in cone.members:
            col = face.A[:, member]
            along_v = bool(np.allclose(col, lay.rim_V[:, s]))
            if not (along_v or np.allclose(col, lay.rim_U[:, s])):
                raise ValueError(f"socp_face's moment {face.names[member]} is not along its "
                                 "trunnion pair's rim directions")
            side.append(s)
            sine.append(along_v)
            which.append(f)
    side, sine, which = np.array(side, int), np.array(sine, bool), np.array(which, int)
    n_pairs = len(pair_x)
    per_face = np.zeros((n_pairs, 2, 2), int)
    np.add.at(per_face, (side, which, sine.astype(int)), 1)
    independent = np.linalg.matrix_rank(np.hstack([lay.rim_U, lay.rim_V])) == 2 * n_pairs
    first = 2 * len(lay.mag) + len(lay.names)  # the rim terms' place in w
    return _FacePlan(checks=face, side=side, sine=sine, slot=2 * side + which,
                     rim_at=first + sine * n_pairs + side, faces=pair_x.ravel(),
                     split=bool(independent and np.all(per_face == 1)))


@dataclass(frozen=True, eq=False)
class _PaperForces:
    """The map from the paper's polar unknowns to the forces it is judged on, at one
    instant: the 36 Cartesian forces (eqs. 11-14, 37-38, 44-45), then with the rim
    each end face's moment (:func:`_face_moments`; ``M``: the moments' columns in the
    rows, ``UV``: the rim directions ``[U, V]`` at this instant). Called on one point
    ``z`` (n_z,); :meth:`stacked` maps the points of many instants at once.
    """

    terms: _Terms
    plan: _FacePlan | None = None
    M: np.ndarray | None = field(default=None, repr=False)
    UV: np.ndarray | None = field(default=None, repr=False)

    def __call__(self, z) -> np.ndarray:
        return self.stacked([self], np.asarray(z, float)[None])[0]

    @staticmethod
    def stacked(maps: list[_PaperForces], Z: np.ndarray) -> np.ndarray:
        """The forces (T, n) of the points ``Z`` (T, n_z), row ``k`` by ``maps[k]``; the
        maps share their :class:`_Terms` (instants of one operator). One vectorized
        pass, for a check pass over a run's instants (far cheaper an instant than the
        per-instant call).
        """
        t = maps[0].terms
        if any(m.terms is not t or m.plan is not maps[0].plan for m in maps):
            raise ValueError("the maps are of different operators")
        w = _polar(t, np.asarray(Z, float).T)
        X = t.forces @ w[:t.forces.shape[1]]  # (n_x, T)
        if not t.rim:
            return X.T
        m, exact = _face_moments(maps[0].plan, w, X)
        if not exact.all():  # a point that is not finite keeps its NaN moments
            for k in np.flatnonzero(~exact & np.isfinite(w).all(axis=0)):
                m[:, k] = maps[k].least_squares(w[:, k], X[:, k])
        return np.concatenate([X, m]).T

    def least_squares(self, w: np.ndarray, x: np.ndarray) -> np.ndarray:
        """The end-face moments as the weighted least-norm (least-squares) ``m`` with
        ``M m`` = the rim terms, by the SVD with the package's rank rule
        (:data:`RANK_RTOL`): where a pair has no pushing face under a nonzero rim term.
        ``M W`` has singular values at 1e-16 relative that are zeros, on which a QR with
        pivoting (``gelsy``) or the SVD at machine precision misjudge the rank and return
        a point other than the least-norm one.
        """
        plan = self.plan
        weight = np.sqrt(np.maximum(x[plan.faces[plan.slot]], 0.0))
        rim = self.UV @ w[len(w) - self.UV.shape[1]:]
        found = scipy.linalg.lstsq(self.M * weight, rim, cond=RANK_RTOL,
                                   check_finite=False)[0]
        return weight * found


def _face_moments(plan: _FacePlan, w: np.ndarray, X: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The end-face moments that carry the rim moments (eqs. 35-36, 42-43) at a stack
    of points (``w``, ``X``: their polar terms and forces, one column each): the
    weighted least-norm ``m`` with ``M m`` = the rim terms, weights
    ``max(f, 0)`` of the owning faces. Where the pairs' rim directions are independent
    and every pair with a rim term has a pushing face, each pair's moment
    ``kf (cos m, sin m)`` is shared by its two faces in proportion to their forces (both
    sit on the same diameter): the least-norm answer in closed form. Returns the
    moments and where they are that answer (elsewhere :meth:`_PaperForces.least_squares`).
    """
    push = np.maximum(X[plan.faces], 0.0)  # (2 pairs, T)
    total = push[0::2] + push[1::2]
    pushing = total > 0.0
    exact = pushing.all(axis=0)
    if not exact.all():  # a pair without a pushing face: exact where it has no rim term
        S = len(total)
        exact = (pushing | ((w[-2 * S:-S] == 0.0) & (w[-S:] == 0.0))).all(axis=0)
    share = push[plan.slot] / (total + ~pushing)[plan.side]
    return share * w[plan.rim_at], exact & plan.split
