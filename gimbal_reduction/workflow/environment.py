"""Is this Snakemake the project's? The check the workflow runs first, at DAG build.

The rules run their stages with the interpreter that runs Snakemake (``sys.executable``), so
a Snakemake from elsewhere (a distribution's /usr/bin/snakemake, a pip install in another
environment, an older pin such as 8.20.5) would run every stage without the project's packages: without Numba the dynamics
would not run (~100x slower without it), without Typst the reports fail at the end.
``problem()`` names what is wrong in one line, with the command that runs the workflow;
``workflow/rules/common.smk`` prints it and stops before anything runs.

Standard library only: it must run under any interpreter, before anything else is imported.
"""
from __future__ import annotations

import importlib.util
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
REQUIREMENTS = ROOT / "workflow" / "envs" / "requirements.txt"
# what the stages import that only the project's environment has (.venv on Python >= 3.12, every
# package from PyPI as pinned in workflow/envs/requirements.txt: DOLFINx 0.11's wheel, Numba, Typst,
# Pint; no system site packages)
MODULES = ("numba", "typst", "pint", "dolfinx")
HOW = ("run it from the project's environment: `make install`, then `. .venv/bin/activate` and "
       "`snakemake --cores 2 all` (or `.venv/bin/python -m snakemake --cores 2 all`)")


def pinned(package: str, requirements: Path = REQUIREMENTS) -> str | None:
    """The version ``package==X`` pins in requirements.txt (None if it is not pinned there)."""
    pattern = re.compile(rf"^\s*{re.escape(package)}\s*==\s*([^\s#;]+)", re.IGNORECASE)
    for line in requirements.read_text().splitlines():
        match = pattern.match(line)
        if match:
            return match.group(1)
    return None


def problem(snakemake_version: str, find_spec=importlib.util.find_spec) -> str | None:
    """One line saying why this Snakemake cannot run the workflow and how to run it, or None."""
    missing = []
    for module in MODULES:
        try:
            found = find_spec(module) is not None
        except (ImportError, ValueError):
            found = False
        if not found:
            missing.append(module)
    want = pinned("snakemake")
    wrong_version = want is not None and snakemake_version != want
    if not missing and not wrong_version:
        return None
    what = []
    if wrong_version:
        what.append(f"Snakemake {snakemake_version} (the project pins {want})")
    if missing:
        what.append(f"no {', '.join(missing)} for {sys.executable}")
    return f"environment error: {'; '.join(what)}: {HOW}"
