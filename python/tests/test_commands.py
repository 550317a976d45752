"""The program's commands from Python: keyword arguments, outputs, progress and errors."""

import ast
import json
import logging
import os
import signal
import threading
import time
from pathlib import Path

import pytest

import mpmrom
from conftest import SEED_SCENE


def test_import_names_the_build():
    info = mpmrom.runtime_info()
    assert info["precision"] == mpmrom.precision
    assert info["version"] == mpmrom.__version__
    assert info["backend"] in ("Serial", "OpenMP", "Cuda")
    assert info["threads"] >= 1


def test_simulate_writes_its_snapshot_and_reports_progress(tmp_path):
    lines = []
    out = mpmrom.simulate(SEED_SCENE, tmp_path / "run.h5", set={"push": 0.7}, progress=lines.append)
    assert out.is_file() and (tmp_path / "run.xmf").is_file()
    assert any("mpmrom simulate" in line for line in lines)


def test_progress_goes_to_logging_without_a_callback(tmp_path, caplog):
    with caplog.at_level(logging.INFO, logger="mpmrom"):
        mpmrom.simulate(SEED_SCENE, tmp_path / "run.h5")
    assert any("mpmrom simulate" in r.getMessage() for r in caplog.records)


def test_info_json_matches_runtime_info():
    assert json.loads(mpmrom.run("info", "--json"))["backend"] == mpmrom.runtime_info()["backend"]


def test_help_lists_the_options():
    assert "--lambda-grad" in mpmrom.help("train")


@pytest.mark.parametrize("command", ["simulate", "sweep", "train", "rollout", "evaluate"])
def test_the_stub_declares_every_option_as_a_keyword(command):
    """The installed _commands.pyi (generated from the parser) gives each option a keyword an editor completes."""
    stub = ast.parse((Path(mpmrom.__file__).parent / "_commands.pyi").read_text())
    function = next(f for f in stub.body if isinstance(f, ast.FunctionDef) and f.name == command)
    keywords = {a.arg for a in function.args.args + function.args.kwonlyargs}
    options = {o["name"].replace("-", "_") for o in mpmrom._core.command_options(command)}
    assert options - {"json"} <= keywords  # evaluate asks for JSON itself
    assert function.args.kwarg is None and ast.get_docstring(function)
    if command == "train":
        assert "lambda_grad" in keywords and "Adam learning rate" in ast.get_docstring(function)


def test_a_bad_scene_raises_the_programs_line(tmp_path):
    scene = tmp_path / "bad.toml"
    scene.write_text('name = "bad"\n[material]\nyoungs_modulus = "soft"\n')
    with pytest.raises(mpmrom.Error, match=r"^mpmrom: error: .*bad.toml") as raised:
        mpmrom.simulate(scene, tmp_path / "run.h5")
    assert "\n" not in str(raised.value)
    assert not (tmp_path / "run.h5").exists()


def test_an_unknown_option_raises():
    with pytest.raises(mpmrom.Error, match="--no-such-option"):
        mpmrom.simulate(SEED_SCENE, "x.h5", no_such_option=3)


def test_a_failing_progress_callback_raises_after_the_command(tmp_path):
    def broken(line):
        raise KeyError("callback")

    with pytest.raises(KeyError):
        mpmrom.simulate(SEED_SCENE, tmp_path / "run.h5", progress=broken)
    assert (tmp_path / "run.h5").is_file()  # the command itself finished


def test_evaluate_returns_the_errors(tiny, tmp_path):
    rom = mpmrom.rollout(tiny["model"], tiny["scene"], tmp_path / "rom.h5")
    errors = mpmrom.evaluate(rom, tiny["sweep"])
    assert isinstance(errors, dict) and errors


def test_ctrl_c_stops_a_command_at_its_next_progress_point(tiny, tmp_path):
    """SIGINT while a long training runs (the lock released) raises KeyboardInterrupt within an epoch or so, and
    leaves no model file behind."""
    out = tmp_path / "model.h5"
    # Python leaves SIGINT ignored when it starts with it ignored (a shell's background job without job control):
    # Ctrl-C's handler is set here so that the test does not depend on how it was launched.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    timer = threading.Timer(0.5, os.kill, (os.getpid(), signal.SIGINT))
    start = time.perf_counter()
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            mpmrom.train(tiny["sweep"], out, latent=2, width=8, depth=3, epochs=1000000, progress=lambda line: None)
    finally:
        timer.cancel()
        signal.signal(signal.SIGINT, previous)
    # A million epochs take many minutes; stopping at the next epoch takes well under the 60 s allowed here.
    assert time.perf_counter() - start < 60
    assert not out.exists()
    # The process is fine afterwards: the next command runs.
    assert json.loads(mpmrom.run("info", "--json"))["backend"]
