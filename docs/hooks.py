"""MkDocs hooks: the generated parts of the site.

- ``on_config``: the package's layers sit at the repository's top level and install as
  subpackages of ``cardan_forces`` (``[tool.setuptools.package-dir]``); mkdocstrings
  reads source files, so the same layout is laid out under ``build/api_src`` as links.
- ``on_page_content``: the docstrings' Sphinx roles (``:func:``) are dropped, their
  names kept as code.
- ``on_page_markdown``: a placeholder ``<!-- generated: NAME -->`` in a page is replaced by
  what ``docs/gen_reference.py`` generates from the package (commands, scene fields,
  public API, the stored bench run, the changelog).
"""

from __future__ import annotations

import os
import re
import shutil
import sys
from pathlib import Path

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(Path(__file__).resolve().parent))

import gen_reference  # noqa: E402

_FOLDER = ""
"""The working directory the build started in (restored when it ends)."""

GENERATED = {
    "cli": gen_reference.cli_markdown,
    "scene": gen_reference.scene_markdown,
    "scene-dump": lambda: "```toml\n" + gen_reference.scene_dump() + "```\n",
    "api": gen_reference.api_markdown,
    "determinacy": gen_reference.determinacy_markdown,
    "element-kind": gen_reference.element_kind_markdown,
    "formulations": gen_reference.formulations_markdown,
    "backends": gen_reference.backends_markdown,
    "bench": gen_reference.bench_markdown,
    "changelog": lambda: (ROOT / "CHANGELOG.md").read_text().split("\n", 1)[1],
}


def api_sources(root: Path = ROOT) -> Path:
    """``build/api_src/cardan_forces``: the installed package's layout, as links."""
    dirs = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-dir"]
    target = root / "build" / "api_src"
    shutil.rmtree(target, ignore_errors=True)
    for package, folder in sorted(dirs.items()):
        place = target.joinpath(*package.split("."))
        if not any(other.startswith(package + ".") for other in dirs):
            place.symlink_to(root / folder, target_is_directory=True)
            continue
        place.mkdir(parents=True)  # a package with subpackages mapped elsewhere
        for entry in (root / folder).iterdir():
            if f"{package}.{entry.name}" not in dirs and entry.name != "__pycache__":
                (place / entry.name).symlink_to(entry)
    return target


def on_startup(**kwargs):
    """Lay out the API sources before any plugin reads its configuration (mkdocstrings
    keeps only the source folders that exist when it starts).
    """
    api_sources()


def on_config(config, **kwargs):
    """Build from ``build/``: the API reader takes a folder named like the package in the
    working directory for the package itself, and the repository's ``cardan_forces/``
    holds only its top layer.
    """
    api_sources()
    global _FOLDER
    _FOLDER = os.getcwd()
    os.chdir(ROOT / "build")
    return config


def on_shutdown(**kwargs):
    if _FOLDER:
        os.chdir(_FOLDER)


ROLE = re.compile(r":(?:py:)?(?:func|meth|class|mod|data|attr|exc|obj):(?=<code>)")
"""A Sphinx role left before its code span in a rendered docstring (``:func:`solve```)."""


def on_page_content(html: str, page, config, files, **kwargs) -> str:
    """The API pages without the docstrings' Sphinx roles: their names stay as code."""
    return ROLE.sub("", html)


def on_page_markdown(markdown: str, page, config, files, **kwargs) -> str:
    for name, generate in GENERATED.items():
        placeholder = f"<!-- generated: {name} -->"
        if placeholder in markdown:
            markdown = markdown.replace(placeholder, generate())
    return markdown
