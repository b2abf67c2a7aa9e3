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
from cardan_forces.driveline.determinacy import RANK_RTOL
from cardan_forces.driveline.equilibrium import Operator
from cardan_forces.driveline.kinematics import rest_geometry
from cardan_forces.driveline.scene import Scene

from .convex import NotApplicable, socp_face
from .problems import NLS, ForceChecks, LastMade

TINY = 1e-12
"""Relative magnitude under which a start's contact angle is set to 0."""

_FB_ORIGIN = 1.0 / np.sqrt(2.0) - 1.0
"""Generalized derivative of ``sqrt(a^2 + b^2) - a - b`` at (0, 0) in a and b."""


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
    yokes = {(c.joint, c.trunnion): (c.body, c.other) for c in op.of_kind("end-face")}
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
    kinds = {c.kind for c in op.contacts}
    if "slip" in kinds or "bearing-floating" in kinds:
        raise NotApplicable(
            "the paper's method (34 polar unknowns, eqs. 49-62) does not apply to scenes "
            "with slip joints or floating bearings: it writes every bearing as locating "
            "and every joint as a cross-pin")
    bearings = op.of_kind("bearing-locating")
    unknowns = 2 * len(bearings) + len({c.shaft for c in bearings}) + 12 * len(op.scene.joints)
    equations = op.A.shape[1] + 2 * len(op.scene.joints)
    if unknowns != equations:
        raise NotApplicable(
            f"the paper's method does not apply to this layout: its polar unknowns "
            f"({unknowns}) and equations ({equations}) differ (it is square, 34 x 34, for "
            "the paper's 3 shafts, 2 joints and 2 bearings on each end shaft)")


def _to_forces(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """Polar unknowns -> the 36 Cartesian forces (eqs. 11-14, 37-38, 44-45)."""
    f, a = z[lay.mag], z[lay.ang]
    return lay.P @ (f * np.cos(a)) + lay.Q @ (f * np.sin(a)) + lay.L @ z


def _rim_terms(lay: _Layout, z: np.ndarray) -> tuple[np.ndarray, ...]:
    """Per trunnion pair, the rim moment's size and direction (eqs. 33-36, 42-43): the
    moment is ``kf (cos m U + sin m V)`` with ``kf = k (f_a + f_b)``,
    ``k = -rt Sgn(sin((t_b - t_a)/2))`` and ``m = (t_a + t_b)/2``; returns
    ``(kf, m, k, fsum)`` (``Sgn`` is piecewise constant: its derivative is 0).
    """
    ta, tb = z[lay.rim_t[:, 0]], z[lay.rim_t[:, 1]]
    fsum = z[lay.rim_f[:, 0]] + z[lay.rim_f[:, 1]]
    k = -lay.rim_r * np.sign(np.sin(0.5 * (tb - ta)))
    return k * fsum, 0.5 * (ta + tb), k, fsum


def _rim_moments(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """The rim moments of the end faces in the Newton-Euler rows (eqs. 50-58)."""
    kf, m = _rim_terms(lay, z)[:2]
    return lay.rim_U @ (kf * np.cos(m)) + lay.rim_V @ (kf * np.sin(m))


@dataclass(frozen=True)
class _Rows:
    """The Newton-Euler rows (eqs. 49-58) at one instant with the operator's ``A`` taken
    into the layout's maps once (``A P``, ``A Q``, ``A L``), so that an evaluation is one
    product over the stacked polar terms instead of building the 36 forces first.
    """

    B: np.ndarray  # (rows, 2 n_polar + n_z [+ 2 n_sides]): [A P, A Q, A L (, U, V)]
    b: np.ndarray
    n_polar: int
    n_z: int


def _rows(lay: _Layout, A: np.ndarray, b: np.ndarray, rim: bool) -> _Rows:
    """:class:`_Rows` of ``A x(z) (+ rim moments) = b`` at one instant."""
    blocks = [A @ lay.P, A @ lay.Q, A @ lay.L] + ([lay.rim_U, lay.rim_V] if rim else [])
    return _Rows(B=np.hstack(blocks), b=b, n_polar=len(lay.mag), n_z=len(lay.names))


def _residual(lay: _Layout, rows: _Rows, z: np.ndarray) -> np.ndarray:
    """The paper's residual ``F(z)``: Newton-Euler rows (eqs. 49-58, with the rim
    moments when ``rows`` has them) then the Fischer-Burmeister rows (eqs. 59-62).
    """
    f, a = z[lay.mag], z[lay.ang]
    if rows.B.shape[1] > 2 * rows.n_polar + rows.n_z:
        kf, m = _rim_terms(lay, z)[:2]
        angle = np.concatenate([a, m])
        c, s = np.cos(angle), np.sin(angle)
        p = rows.n_polar
        w = np.concatenate([f * c[:p], f * s[:p], z, kf * c[p:], kf * s[p:]])
    else:
        w = np.concatenate([f * np.cos(a), f * np.sin(a), z])
    return np.concatenate([rows.B @ w - rows.b, _fb_rows(lay, z)])


def _jacobian(lay: _Layout, rows: _Rows, z: np.ndarray) -> np.ndarray:
    """Jacobian of :func:`_residual` (rows x n_z). The rim moments' columns: each pair's
    two end-face forces and two contact angles enter once (distinct unknowns per pair).
    """
    p, n = rows.n_polar, rows.n_z
    AP, AQ = rows.B[:, :p], rows.B[:, p:2 * p]
    f, a = z[lay.mag], z[lay.ang]
    c, s = np.cos(a), np.sin(a)
    J = rows.B[:, 2 * p:2 * p + n].copy()
    J[:, lay.mag] += AP * c + AQ * s
    J[:, lay.ang] += (AQ * c - AP * s) * f
    if rows.B.shape[1] > 2 * p + n:
        U, V = rows.B[:, 2 * p + n:].reshape(len(rows.b), 2, -1).transpose(1, 0, 2)
        kf, m, k = _rim_terms(lay, z)[:3]
        cm, sm = np.cos(m), np.sin(m)
        along, turn = (U * cm + V * sm) * k, (V * cm - U * sm) * (0.5 * kf)
        for col in (0, 1):
            J[:, lay.rim_f[:, col]] += along
            J[:, lay.rim_t[:, col]] += turn
    return np.vstack([J, _fb_jacobian(lay, z)])


def _fb_rows(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """Fischer-Burmeister rows (eqs. 59-62): ``sqrt(a^2 + b^2) - a - b`` per pair."""
    a, b = z[lay.fb[:, 0]], z[lay.fb[:, 1]]
    return np.hypot(a, b) - a - b


def _fb_jacobian(lay: _Layout, z: np.ndarray) -> np.ndarray:
    """The (generalized) Jacobian of the Fischer-Burmeister rows (:func:`_fb_rows`)."""
    a, b = z[lay.fb[:, 0]], z[lay.fb[:, 1]]
    r = np.hypot(a, b)
    safe = np.where(r > 0, r, 1.0)
    da = np.where(r > 0, a / safe - 1.0, _FB_ORIGIN)
    db = np.where(r > 0, b / safe - 1.0, _FB_ORIGIN)
    J = np.zeros((len(a), len(z)))
    rows = np.arange(len(a))
    J[rows, lay.fb[:, 0]] = da
    J[rows, lay.fb[:, 1]] = db
    return J


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


def build_paper(op: Operator, i: int, rim: bool = True, scene: Scene | None = None) -> PaperNLS:
    """The paper's system (eqs. 49-62) at instant ``i`` of ``op``.

    ``scene`` (default: the operator's) supplies the shaft axes for the bearing angles
    and the rim radius ``rt``. With ``rim=True`` the answer is judged in ``socp_face``'s
    force space (forces plus end-face moments, the rim moments being such moments on
    the cone's boundary), so the package's residuals check the paper's own model;
    ``paper_residual(z)`` is ``||F(z)|| / ||b||`` of the paper's equations.
    """
    scene = op.scene if scene is None else scene
    applies(op)
    lay = _layout(op, i, scene)
    A, b = op.A[i], op.b[i]
    scale = max(float(np.linalg.norm(b)), 1e-12)
    rows = _rows(lay, A, b, rim)

    def fun(z):
        return _residual(lay, rows, np.asarray(z, float))

    def jac(z):
        return _jacobian(lay, rows, np.asarray(z, float))

    if rim:
        # judged in the force space of ``socp_face``: the rim moments become end-face
        # moments, which the centre-of-pressure cone ||m|| <= rt f must contain
        plan = _face_plan(op, scene)
        M = np.where(plan.sine, lay.rim_V[:, plan.side], lay.rim_U[:, plan.side])
        checks = dataclasses.replace(plan.checks, A=np.hstack([A, M]), b=b)

        def to_forces(z):
            z = np.asarray(z, float)
            x = _to_forces(lay, z)
            return np.concatenate([x, _face_moments(lay, plan, M, x, z)])
    else:
        checks = ForceChecks(A=A, b=b, names=op.names, unilateral=op.unilateral,
                             pairs=op.pairs)

        def to_forces(z):
            return _to_forces(lay, np.asarray(z, float))
    return PaperNLS(
        checks=checks, formulation="paper", to_forces=to_forces,
        fun=fun, jac=jac, z0=_start(op, i, lay), unknown_names=lay.names,
        paper_residual=lambda z: float(np.linalg.norm(fun(z))) / scale,
        rim=rim, radial=lay.mag, angles=lay.ang, end_faces=lay.fb.ravel(),
    )


@dataclass(frozen=True)
class _FacePlan:
    """``socp_face``'s force space for the paper's answers, the same at every instant
    of an operator: its checks at the first instant (names, signs, pairs, cones; ``A``
    and ``b`` are replaced per instant), and per end-face moment unknown its trunnion
    pair (``side``), whether it lies along the pair's ``V`` (sine) rim direction or its
    ``U`` (cosine) one, and which face of the pair owns it (``face``, 0 or 1).
    ``pair_x`` (pairs, 2): the faces' force columns.
    ``split``: every face has one moment along ``U`` and one along ``V`` and the pairs'
    rim directions are independent, so :func:`_face_moments` has its closed form.
    """

    checks: ForceChecks
    side: np.ndarray
    sine: np.ndarray
    face: np.ndarray
    pair_x: np.ndarray
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
    return _FacePlan(checks=face, side=side, sine=sine, face=which, pair_x=pair_x,
                     split=bool(independent and np.all(per_face == 1)))


def _face_moments(lay: _Layout, plan: _FacePlan, M: np.ndarray, x: np.ndarray,
                  z: np.ndarray) -> np.ndarray:
    """The end-face moments that carry the rim moments (eqs. 35-36, 42-43): the
    weighted least-norm ``m`` with ``M m`` = the rim terms, weights ``max(f, 0)`` of
    the owning faces. Where the pairs' rim directions are independent and every pair
    has a pushing face, each pair's moment ``kf (cos m, sin m)`` is shared by its two
    faces in proportion to their forces (both sit on the same diameter): that is the
    least-norm answer in closed form. Otherwise (no pushing face under a nonzero rim
    term) the least-squares split by the SVD with the package's rank rule
    (:data:`RANK_RTOL`): ``M W`` has singular values at 1e-16 relative that are zeros,
    on which a QR with pivoting (``gelsy``) or the SVD at machine precision misjudge the
    rank and return a point other than the least-norm one.
    """
    kf, m = _rim_terms(lay, z)[:2]
    push = np.maximum(x[plan.pair_x], 0.0)
    total = push[:, 0] + push[:, 1]
    if plan.split and not np.any((total <= 0.0) & (kf != 0.0)):
        share = push / np.where(total > 0.0, total, 1.0)[:, None]
        along = np.where(plan.sine, np.sin(m)[plan.side], np.cos(m)[plan.side])
        return share[plan.side, plan.face] * kf[plan.side] * along
    weight = np.sqrt(push[plan.side, plan.face])
    found = scipy.linalg.lstsq(M * weight, _rim_moments(lay, z), cond=RANK_RTOL,
                               check_finite=False)[0]
    return weight * found
