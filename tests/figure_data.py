"""Two runs' figure CSVs compared as the figures' data: the unique members to rounding,
the others by what defines them (a helper of the tests, not a test module)."""

import numpy as np
from cardan_forces.formulations import BASELINE, FORMULATIONS


def numbers(path):
    """A figure CSV's header and its cells as floats (an empty cell, no number: NaN)."""
    rows = [line.split(",") for line in path.read_text().splitlines()]
    cells = [[float(c) if c else np.nan for c in row] for row in rows[1:]]
    return rows[0], np.array(cells, float)


UNIQUE = tuple(f for f, r in FORMULATIONS.items() if r.least_norm_batch)
"""Methods whose answer is unique (strictly convex least norms): the same on any
install to rounding. ``min_max``'s optimal face is not a point: where its answer lands
a change in the last digits of ``A(t)`` moves (the motion is integrated compiled with
numba or in NumPy), so it is held to the rigid set instead; the paper's root finder
jumps between roots as its text says, and its end faces act at the rim (eqs. 33-36),
so it is held to the report's verdicts alone."""


def method(column: str) -> str | None:
    return next((f for f in FORMULATIONS if column.endswith(f"_{f}")), None)


def inside_the_set(head: list[str], x: np.ndarray, column: int) -> bool:
    """Column ``column`` (a method's force) lies in its quantity's rigid set at every
    instant where the CSV bounds it (to 1e-6 of the largest force)."""
    quantity = head[column][: -len(method(head[column])) - 1]
    if f"{quantity}_set_min" not in head:
        return True
    lo, hi = (x[:, head.index(f"{quantity}_set_{side}")] for side in ("min", "max"))
    tol = 1e-6 * np.nanmax(np.abs(x[:, 1:]))
    value = x[:, column]
    with np.errstate(invalid="ignore"):
        below, above = value < lo - tol, value > hi + tol
    return not (below | above).any()


def assert_same_figure(a_path, b_path) -> None:
    """The CSVs ``a_path`` and ``b_path`` of one figure hold the same data: the unique
    members (:data:`UNIQUE`), the sets and the motion within 1e-6 of the largest force,
    ``min_max`` inside the rigid set in both; the paper's method is not compared."""
    (head, a), (head_b, b) = numbers(a_path), numbers(b_path)
    assert head == head_b and a.shape == b.shape, a_path.name
    tol = 1e-6 * np.nanmax(np.abs(a[:, 1:]))
    for j, column in enumerate(head):
        if method(column) in UNIQUE or method(column) is None:
            assert np.array_equal(np.isnan(a[:, j]), np.isnan(b[:, j])), (a_path.name, column)
            assert np.nanmax(np.abs(a[:, j] - b[:, j]), initial=0.0) <= tol, (a_path.name,
                                                                              column)
        elif method(column) != BASELINE:
            assert inside_the_set(head, a, j) and inside_the_set(head, b, j), column
