"""What the tests share: the real data, and the command line to compare with."""

import os
import pathlib
import subprocess

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT.parent / "shared" / "data"
BUNNY = DATA / "stanford-bunny"


def cli():
    for c in [os.environ.get("SCANRIG_CLI"), ROOT / "target/debug/scanrig", ROOT / "target/release/scanrig"]:
        if c and pathlib.Path(c).exists():
            return str(c)
    pytest.skip("SKIPPED: no scanrig binary (cargo build, or set SCANRIG_CLI)")


def need(path):
    if not path.exists():
        pytest.skip(f"SKIPPED: {path} is absent (../shared/data)")
    return path


def run(*args):
    r = subprocess.run([cli(), *map(str, args)], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return r
