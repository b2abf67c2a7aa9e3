"""Where the generated solvers are cached: one absolute folder whatever the variables
say (a relative path, a literal ``~``), so that the compiler, which runs in a folder of
its own, writes where the package then looks. Needs neither qocogen nor a compiler."""

from __future__ import annotations

from pathlib import Path

import pytest
from cardan_forces.solvers import qocogen_


@pytest.mark.parametrize("variable, value, expected", [
    ("CARDAN_FORCES_CACHE", "relative/cache", "{cwd}/relative/cache/qocogen"),
    ("CARDAN_FORCES_CACHE", "./a/../b", "{cwd}/a/../b/qocogen"),
    ("CARDAN_FORCES_CACHE", "~/mine", "{home}/mine/qocogen"),
    ("CARDAN_FORCES_CACHE", "~", "{home}/qocogen"),
    ("CARDAN_FORCES_CACHE", "{cwd}/absolute", "{cwd}/absolute/qocogen"),
    ("XDG_CACHE_HOME", "xdg", "{cwd}/xdg/cardan-forces/qocogen"),
    ("XDG_CACHE_HOME", "~/xdg", "{home}/xdg/cardan-forces/qocogen"),
    (None, None, "{home}/.cache/cardan-forces/qocogen"),
])
def test_the_cache_folder_is_absolute_with_home_expanded(tmp_path, monkeypatch, variable,
                                                         value, expected):
    home, cwd = tmp_path / "home", tmp_path / "work"
    cwd.mkdir()
    monkeypatch.chdir(cwd)
    monkeypatch.setenv("HOME", str(home))
    for name in ("CARDAN_FORCES_CACHE", "XDG_CACHE_HOME"):
        monkeypatch.delenv(name, raising=False)
    if variable:
        monkeypatch.setenv(variable, value.format(cwd=cwd))
    found = qocogen_.cache_dir()
    assert found.is_absolute() and "~" not in found.parts
    assert found == Path(expected.format(cwd=cwd, home=home))
