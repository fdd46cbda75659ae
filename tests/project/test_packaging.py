"""A regular (non-editable) wheel ships every module of the core and the plugins."""

from __future__ import annotations

import pytest
import pathlib
import shutil
import subprocess
import sys
import zipfile

ROOT = pathlib.Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_wheel_contains_every_module_and_the_entry_point(tmp_path):
    src = tmp_path / "src"
    shutil.copytree(
        ROOT,
        src,
        ignore=shutil.ignore_patterns(
            ".git", ".venv", "build", "*.egg-info", "site", "__pycache__", ".hypothesis", "examples", "docs"
        ),
    )
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--quiet",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(tmp_path / "dist"),
            str(src),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    (wheel,) = (tmp_path / "dist").glob("gnssframework-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    expected = {p.relative_to(ROOT).as_posix() for p in (ROOT / "gnssframework").rglob("*.py")}
    expected |= {
        "gnssframework_plugins/" + p.relative_to(ROOT / "plugins").as_posix() for p in (ROOT / "plugins").rglob("*.py")
    }
    assert expected - names == set()
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(entry_points).decode()
    assert "[gnssframework]" in text and "builtin = gnssframework_plugins" in text
    assert "scenarios = gnssframework.experiments.scenarios.hooks" in text


@pytest.mark.slow
def test_version_licence_and_citation_are_in_one_place():
    import subprocess
    import sys
    import tomllib
    from pathlib import Path

    import gnssframework

    root = Path(__file__).resolve().parents[2]
    version = tomllib.loads((root / "pyproject.toml").read_text())["project"]["version"]
    assert gnssframework.__version__ == version
    out = subprocess.run([sys.executable, "-m", "gnssframework", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.strip() == f"gnssframework {version}"
    assert "MIT License" in (root / "LICENSE").read_text()
    assert f"version: {version}" in (root / "CITATION.cff").read_text()
    assert (root / "gnssframework" / "py.typed").exists()


def _citation() -> dict[str, str]:
    """The top-level ``key: value`` lines of CITATION.cff (quotes removed)."""
    out = {}
    for line in (ROOT / "CITATION.cff").read_text().splitlines():
        if ":" in line and not line.startswith((" ", "-", "#")):
            key, value = line.split(":", 1)
            out[key.strip()] = value.strip().strip('"')
    return out


def test_the_changelog_is_keep_a_changelog_and_names_the_cited_release():
    import re
    import tomllib

    version = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["version"]
    text = (ROOT / "CHANGELOG.md").read_text()
    releases = re.findall(r"^## \[([^\]]+)\](?: - (\d{4}-\d{2}-\d{2}))?$", text, re.M)
    assert releases[0] == ("Unreleased", "")
    dated = dict(releases[1:])
    cff = _citation()
    assert cff["version"] == version and dated.get(version) == cff["date-released"], (dated, cff)
    # every heading is a release or one of Keep a Changelog's change types
    for heading in re.findall(r"^(#{2,}) (.*)$", text, re.M):
        if heading[0] == "##":
            assert re.fullmatch(r"\[[^\]]+\]( - \d{4}-\d{2}-\d{2})?", heading[1]), heading
        else:
            assert heading == ("###", heading[1]) and heading[1] in {
                "Added",
                "Changed",
                "Deprecated",
                "Removed",
                "Fixed",
                "Security",
            }, heading
    assert "How to cite" in (ROOT / "README.md").read_text()


def test_ci_builds_and_checks_the_wheel_and_sdist_with_the_release_extra():
    import tomllib

    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert {r.split(">")[0].split("=")[0] for r in extras["release"]} >= {"build", "twine"}
    ci = (ROOT / ".ci" / "run").read_text()
    release = ci[ci.index("release() {") : ci.index("lane release release")]
    assert '.[lint,tune,docs,release]"' in ci  # the release extra installed before the lane
    assert "-m build" in release and "--sdist --wheel" in release and "twine check --strict" in release
