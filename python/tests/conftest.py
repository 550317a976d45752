"""A tiny model of the fuzzers' seed scene (a 64-point block pushed by a force, three runs), trained once per test
session through the package's own commands."""

from pathlib import Path

import pytest

import mpmrom

ROOT = Path(__file__).resolve().parents[2]
SEED_SCENE = ROOT / "fuzz" / "seed_scene.toml"
POKE_SCENE = ROOT / "scenes" / "poke_cylinder.toml"


@pytest.fixture(scope="session")
def tiny(tmp_path_factory):
    work = tmp_path_factory.mktemp("tiny")
    sweep = mpmrom.sweep(SEED_SCENE, work / "sweep")
    model = mpmrom.train(sweep, work / "model.h5", latent=2, width=8, depth=3, epochs=50, scene=SEED_SCENE)
    return {"scene": SEED_SCENE, "sweep": sweep, "model": model, "work": work}
