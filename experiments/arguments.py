"""What the command line's layers share: the error for a request that cannot be carried
out (exit code 2) and the argparse types of the options many commands take (an output
folder's is :func:`cardan_forces.experiments.files.folder`, beside the files). It sits
below both the commands (:mod:`cardan_forces.commands`) and the study commands of this
layer, so neither imports the other for them.
"""

from __future__ import annotations

import argparse

from cardan_forces.formulations import UnknownFormulation, formulation


class UsageError(ValueError):
    """A command-line request that cannot be carried out (exit code 2)."""


def whole_number(least: int, most: int):
    """An argparse type: a whole number from ``least`` to ``most`` (a size, a count, a
    seed), refused with one line before any work.
    """
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = least - 1
        if not least <= value <= most:
            raise argparse.ArgumentTypeError(f"expected a whole number from {least} to "
                                             f"{most}, got {text!r}")
        return value
    return parse


def formulation_name(text: str) -> str:
    """An argparse type: a formulation's name, a typo refused in one line naming the
    nearest names (:func:`~cardan_forces.formulations.formulation`).
    """
    try:
        return formulation(text).name
    except UnknownFormulation as err:
        raise argparse.ArgumentTypeError(str(err)) from None
