"""Packaging guard: every subpackage of the source tree is listed in setup.cfg, so the
installed package (what CI's pytest and users import) is never missing one."""
from __future__ import annotations

import configparser
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_every_subpackage_is_packaged():
    cfg_path = ROOT / "setup.cfg"
    if not (ROOT / "oclshade").is_dir() or not cfg_path.is_file():
        pytest.skip("needs the source tree (setup.cfg and oclshade/)")
    cfg = configparser.ConfigParser()
    cfg.read(cfg_path)
    listed = {p.strip() for p in cfg["options"]["packages"].replace("\n", ",").split(",") if p.strip()}
    found = {".".join(d.relative_to(ROOT).parts) for d in (ROOT / "oclshade").rglob("*")
             if d.is_dir() and (d / "__init__.py").is_file() and "__pycache__" not in d.parts}
    found.add("oclshade")
    missing = sorted(found - listed)
    assert not missing, f"setup.cfg [options] packages lacks {missing}: the installed package would not have them"
