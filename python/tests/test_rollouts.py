"""Reduced rollouts from Python: NumPy in and out, bitwise the same as the program's, and clear errors."""

import json
import os
import subprocess
import sys

import h5py
import numpy as np
import pytest

import mpmrom

PUSHES = np.array([[0.6], [1.0], [1.4]])


def write_params(path, names, values):
    with open(path, "w") as f:
        f.write(",".join(names) + "\n")
        for row in values:
            f.write(",".join(repr(float(v)) for v in row) + "\n")


def rollout_latents(rom):
    """Every frame's xhat and xhatdot of every rollout: (size, frames, r) each."""
    with rom.batch(PUSHES) as batch:
        xhat, rate = [batch.latent_state()], [batch.latent_rate()]
        while batch.advance():
            xhat.append(batch.latent_state())
            rate.append(batch.latent_rate())
        return np.stack(xhat, axis=1), np.stack(rate, axis=1)


def test_a_batch_is_bitwise_the_programs_rollout(tiny, tmp_path):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    params = tmp_path / "params.csv"
    write_params(params, rom.parameter_names, PUSHES)
    xhat, rate = rollout_latents(rom)
    outputs = [mpmrom.rollout(tiny["model"], tiny["scene"], tmp_path / "in_process.h5", params=params)]
    # The program itself, where the test run names it (scripts/python.sh: the C++ build of the same commit).
    cli = os.environ.get("MPMROM_CLI")
    if cli:
        subprocess.run([cli, "-q", "rollout", str(tiny["model"]), str(tiny["scene"]), "--out",
                        str(tmp_path / "cli.h5"), "--params", str(params)], check=True)
        outputs.append(tmp_path / "cli.h5")
    for path in outputs:
        with h5py.File(path, "r") as f:
            # Same code, same inputs, same order of operations: equal to the last bit, no tolerance.
            np.testing.assert_array_equal(f["latent/xhat"][...], xhat)
            np.testing.assert_array_equal(f["latent/xhatdot"][...], rate)


def test_the_batch_reports_its_shape_and_times(tiny):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    assert rom.parameter_names == ["push"]
    with rom.batch(PUSHES) as batch:
        assert (len(batch), batch.latent_dim, batch.frame) == (3, 2, 0)
        assert batch.latent_state().shape == (3, 2)
        batch.run()
        assert batch.frame == batch.frames - 1
        assert batch.time == pytest.approx(batch.times[-1])
        assert not batch.advance()
        assert batch.running().all()
        assert all(o.stopped_at == -1 and not o.message for o in batch.outcomes())


def test_decoded_fields_at_the_start_are_the_reference_body(tiny):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    X = rom.reference_points
    with rom.batch(PUSHES) as batch:
        x, v, F = batch.decode(1, X)
        assert x.shape == (len(X), 3) and v.shape == (len(X), 3) and F.shape == (len(X), 3, 3)
        # The initial state is the manifold's projection of the undeformed body: its error is the tiny model's
        # reconstruction error, a small fraction of the block's 0.2 m size (1 mm bounds it with room for a 50-epoch
        # network; an unprojected or misread state is off by centimetres).
        assert np.abs(x - X).max() < 1e-3
        np.testing.assert_array_equal(batch.positions(X)[1], x)


def test_decoding_every_rollout_at_once_is_decoding_each(tiny):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    X = rom.reference_points[::7]
    with rom.batch(PUSHES) as batch:
        batch.advance()
        every = batch.decode_all(X)
        assert every.x.shape == (3, len(X), 3) and every.F.shape == (3, len(X), 3, 3)
        for rollout in range(3):
            # Each (rollout, point) is the same network evaluation in either pass: equal to the last bit.
            for field, alone in zip(every, batch.decode(rollout, X)):
                np.testing.assert_array_equal(field[rollout], alone)


def host_array(dlpack_array):
    """A DLPack array's values as NumPy: directly on the host, through CuPy from a CUDA GPU (skipped without it)."""
    kDLCPU, kDLCUDA = 1, 2
    device_type, _ = dlpack_array.__dlpack_device__()
    if device_type == kDLCPU:
        return np.from_dlpack(dlpack_array)
    assert device_type == kDLCUDA
    cupy = pytest.importorskip("cupy")
    return cupy.asnumpy(cupy.from_dlpack(dlpack_array))


def test_latent_states_on_the_device_are_dlpack_arrays(tiny):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    batch = rom.batch(PUSHES)
    batch.advance()
    state, rate = batch.latent_state(device=True), batch.latent_rate(device=True)
    expected = batch.latent_state(), batch.latent_rate()
    batch.advance()  # a snapshot: later steps leave it as it was
    batch.free()
    on_gpu = mpmrom.runtime_info()["backend"] == "Cuda"
    assert state.__dlpack_device__()[0] == (2 if on_gpu else 1)  # kDLCUDA, kDLCPU
    dtype = np.float32 if mpmrom.precision == "float" else np.float64
    for on_device, host in zip((state, rate), expected):
        array = host_array(on_device)
        assert array.dtype == dtype and array.shape == (3, 2)
        # The same values: the host copy is the device's widened to float64.
        np.testing.assert_array_equal(array.astype(np.float64), host)


def test_arrays_outlive_their_batch(tiny):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    batch = rom.batch(PUSHES)
    batch.advance()
    state = batch.latent_state()
    expected = state.copy()
    x = batch.decode(0, rom.reference_points).x
    batch.free()
    del batch
    np.testing.assert_array_equal(state, expected)
    assert np.isfinite(x).all()


def test_a_freed_batch_raises(tiny):
    batch = mpmrom.ReducedModel(tiny["model"], tiny["scene"]).batch(PUSHES)
    batch.free()
    with pytest.raises(mpmrom.Error, match="freed"):
        batch.advance()


def test_settings_are_the_rollout_options(tiny):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"], samples=0, projection="position")
    assert rom.settings.samples == 0 and rom.settings.projection == "position"
    assert len(rom.samples) == len(rom.reference_points)
    assert mpmrom.RomSettings.defaults("galerkin").to_dict()["method"] == "galerkin"
    # A method keyword starts from that method's defaults, as `mpmrom rollout --method galerkin` does.
    galerkin = mpmrom.ReducedModel(tiny["model"], tiny["scene"], method="galerkin", samples=8).settings
    assert galerkin.to_dict() == {**mpmrom.RomSettings.defaults("galerkin").to_dict(), "samples": 8}


@pytest.mark.parametrize("values, error, message", [
    ([["a"], ["b"]], TypeError, "real numbers"),
    (np.array([1 + 2j]), TypeError, "real numbers"),
    (np.ones((2, 2)), ValueError, r"shape \(n, 1\)"),
    (np.array([[1.0], [np.nan]]), ValueError, "row 1"),
    (np.zeros((0, 1)), ValueError, "at least one row"),
])
def test_bad_parameter_values_raise(tiny, values, error, message):
    rom = mpmrom.ReducedModel(tiny["model"], tiny["scene"])
    with pytest.raises(error, match=message):
        rom.batch(values)


def test_bad_settings_and_indices_raise(tiny):
    with pytest.raises(TypeError, match="no setting 'sample'"):
        mpmrom.ReducedModel(tiny["model"], tiny["scene"], sample=3)
    with pytest.raises(ValueError, match="projection"):
        mpmrom.ReducedModel(tiny["model"], tiny["scene"], projection="sideways")
    with mpmrom.ReducedModel(tiny["model"], tiny["scene"]).batch(PUSHES) as batch:
        with pytest.raises(IndexError):
            batch.decode(3, [[0.0, 0.0, 0.0]])
        with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
            batch.decode(0, np.zeros((4, 2)))


def test_a_model_for_another_scene_raises(tiny):
    from conftest import POKE_SCENE
    with pytest.raises(mpmrom.Error, match="scene"):
        mpmrom.ReducedModel(tiny["model"], POKE_SCENE).batch([[1.0, 4.5, 12.5]])


def test_a_batch_alive_at_exit_is_freed_before_kokkos(tiny):
    """A batch and a device array left alive to interpreter exit free their Views before Kokkos stops: a clean exit,
    no warning."""
    code = ("import sys, mpmrom\n"
            "rom = mpmrom.ReducedModel(sys.argv[1], sys.argv[2])\n"
            "batch = rom.batch([[1.0], [1.2]])\n"
            "batch.advance()\n"
            "state = batch.latent_state(device=True)\n")
    done = subprocess.run([sys.executable, "-c", code, str(tiny["model"]), str(tiny["scene"])],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "leak" not in done.stderr and "Kokkos" not in done.stderr, done.stderr


@pytest.mark.parametrize("method, samples", [("point", "0"), ("galerkin", "8")])
def test_the_design_example_finds_a_load(tiny, method, samples):
    from conftest import ROOT
    done = subprocess.run([sys.executable, str(ROOT / "examples" / "python" / "design.py"), str(tiny["model"]),
                           str(tiny["scene"]), "--target", "push=1.2", "--population", "32", "--iterations", "3",
                           "--method", method, "--samples", samples], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    result = json.loads(done.stdout)
    assert 0.5 <= result["found_parameters"][0] <= 1.5  # inside the design's range
    # The tip the found load reaches, checked with the full-order model, is closer to the target than the tip at rest
    # (the target's own displacement): the search moved toward the answer, not away from it.
    displacement = np.linalg.norm(np.array(result["target_tip"]) - result["tip_reference"])
    assert result["full_order_miss_m"] < displacement
    assert result["loop_seconds_reduced"] > 0 and result["rollouts"] == 96 and result["method"] == method
