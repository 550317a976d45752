"""A trained model as batches of reduced rollouts, NumPy in and out (the C++ deployment API, docs/api.md)."""

from __future__ import annotations

import os
from typing import Any, NamedTuple, Optional, Union

import numpy as np

from . import _core

PathLike = Union[str, "os.PathLike[str]"]


class DecodedFields(NamedTuple):
    """Fields at n reference points: positions x (n, 3), velocities v (n, 3), gradients F (n, 3, 3); from
    `RolloutBatch.decode_all` each with a leading axis of rollouts."""

    x: np.ndarray
    v: np.ndarray
    F: np.ndarray


def _float_rows(values: Any, columns: int, what: str) -> np.ndarray:
    """`values` as a C-contiguous float64 (n, columns) array (one row given alone is (1, columns)); raises TypeError
    for non-numbers and ValueError for another shape or a value that is not finite."""
    array = np.asarray(values)
    if array.dtype == object or not (np.issubdtype(array.dtype, np.number) or array.dtype == bool) or \
            np.issubdtype(array.dtype, np.complexfloating):
        raise TypeError(f"{what} must be real numbers, not {array.dtype}")
    array = np.ascontiguousarray(array, dtype=np.float64)
    if array.ndim == 1 and columns == 1:
        array = array.reshape(-1, 1)  # one parameter: a value per rollout
    elif array.ndim == 1 and array.size == columns:
        array = array.reshape(1, columns)
    if array.ndim != 2 or array.shape[1] != columns:
        raise ValueError(f"{what} must have shape (n, {columns}), not {array.shape}")
    if not np.isfinite(array).all():
        row = int(np.argwhere(~np.isfinite(array))[0][0])
        raise ValueError(f"{what}: row {row} holds a value that is not finite")
    return array


class RolloutBatch:
    """Rollouts of one model advanced together, output interval by output interval.

    Use it as a context manager (or call `free`) to release its memory at once. Arrays it returns are the caller's:
    they stay valid after the batch is gone.
    """

    def __init__(self, core: _core.RolloutBatch, parameter_values: np.ndarray):
        self._core = core
        self.parameter_values = parameter_values

    def __enter__(self) -> "RolloutBatch":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.free()

    def __len__(self) -> int:
        return self._core.size

    @property
    def size(self) -> int:
        """Rollouts in the batch."""
        return self._core.size

    @property
    def latent_dim(self) -> int:
        return self._core.latent_dim

    @property
    def frame(self) -> int:
        """The output frame reached: 0 (the initial state) to frames - 1."""
        return self._core.frame

    @property
    def frames(self) -> int:
        return self._core.frames

    @property
    def time(self) -> float:
        """Time (s) of `frame`."""
        return self._core.time

    @property
    def times(self) -> np.ndarray:
        """Every output time (s), `frames` of them."""
        return np.asarray(self._core.times)

    @property
    def steps(self) -> int:
        """Time steps taken so far (each advances every rollout)."""
        return self._core.steps

    def advance(self) -> bool:
        """Advances every running rollout to the next output time; False, doing nothing, at the horizon."""
        return self._core.advance()

    def run(self) -> "RolloutBatch":
        """Advances to the horizon."""
        while self._core.advance():
            pass
        return self

    def latent_state(self, device: bool = False) -> Any:
        """xhat now, (size, r): a float64 NumPy array, or with device=True a copy left in the memory the batch runs
        in (the GPU's in a CUDA build), in the build's precision, for `torch.from_dlpack`, `cupy.from_dlpack` or
        `np.from_dlpack` (on the host)."""
        return self._core.latent_state_on_device() if device else self._core.latent_state()

    def latent_rate(self, device: bool = False) -> Any:
        """xhatdot now, (size, r); device=True as in `latent_state`."""
        return self._core.latent_rate_on_device() if device else self._core.latent_rate()

    def outcomes(self) -> list[_core.Outcome]:
        """Each rollout's flags, stop time and message, and a warning for parameters outside the training range."""
        return self._core.outcomes()

    def running(self) -> np.ndarray:
        """Whether each rollout still runs (False once a detector stopped it, docs/stability.md), (size,)."""
        return np.array([self._core.running(i) for i in range(self._core.size)], dtype=bool)

    def decode(self, rollout: int, points: Any) -> DecodedFields:
        """Rollout `rollout`'s fields now at reference points (n, 3)."""
        if not 0 <= rollout < self._core.size:
            raise IndexError(f"rollout {rollout} of {self._core.size}")
        return DecodedFields(*self._core.decode(rollout, _float_rows(points, 3, "points")))

    def decode_all(self, points: Any) -> DecodedFields:
        """Every rollout's fields now at the same reference points (n, 3), in one pass of the network: x and v
        (size, n, 3), F (size, n, 3, 3). A stopped rollout's fields are those of its last state."""
        return DecodedFields(*self._core.decode_all(_float_rows(points, 3, "points")))

    def positions(self, points: Any) -> np.ndarray:
        """Every rollout's positions now at reference points (n, 3): (size, n, 3)."""
        return self.decode_all(points).x

    def free(self) -> None:
        """Releases the batch's memory now; later calls raise mpmrom.Error."""
        self._core.free()


class ReducedModel:
    """A trained model (`mpmrom train`) on its scene, ready to run batches of reduced rollouts.

    Settings are `mpmrom rollout`'s options as keywords (`samples=30`, `method="node"`, `end_time=0.5`; see
    `mpmrom.RomSettings`), starting, as the program does, from the measured defaults of the method asked for
    (`RomSettings.defaults`), or a whole `settings=RomSettings(...)`. Loading selects the sample points, which for a
    sample count the model does not store takes a fit over the training design (docs/rom.md "Sample selection").
    """

    def __init__(self, model: PathLike, scene: PathLike, settings: Optional[_core.RomSettings] = None,
                 **options: Any):
        if settings is not None:
            chosen = settings
        else:
            chosen = _core.RomSettings.defaults(options.get("method", "point"))
        for name, value in options.items():
            if name.startswith("_") or not hasattr(chosen, name):
                raise TypeError(f"ReducedModel: no setting '{name}' (see mpmrom.RomSettings)")
            setattr(chosen, name, value)
        self._core = _core.ReducedModel(os.fspath(model), os.fspath(scene), chosen)

    @property
    def parameter_names(self) -> list[str]:
        """The order of a batch's parameter columns."""
        return self._core.parameter_names

    @property
    def settings(self) -> _core.RomSettings:
        return self._core.settings

    @property
    def latent_dim(self) -> int:
        return self._core.latent_dim

    @property
    def samples(self) -> list[int]:
        """The sample points, indices into reference_points."""
        return self._core.samples

    @property
    def reference_points(self) -> np.ndarray:
        """The model's material points in the reference configuration, (n, 3)."""
        return self._core.reference_points()

    def batch(self, parameter_values: Any) -> RolloutBatch:
        """One rollout per row of parameter values, (n, len(parameter_names)), at the scene's initial state."""
        values = _float_rows(parameter_values, len(self.parameter_names), "parameter values")
        return RolloutBatch(self._core.batch(values), values)
