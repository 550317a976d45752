"""mpmrom: the material point method and its neural reduced-order model, on Kokkos (docs/python.md).

The full-order model and the program's commands (`simulate`, `sweep`, `train`, `rollout`, `evaluate`, or any
command through `run`) take the command line's options as keyword arguments; a trained model runs as batches of
reduced rollouts (`ReducedModel`, `RolloutBatch`) with NumPy arrays in and out. Kokkos starts on the first call that
needs it (`initialize` chooses its threads) and stops at interpreter exit. Errors raise `Error`, with the program's
one-line message.
"""

from ._core import Error, Outcome, RomSettings, SimulationFailed, __version__, initialize, precision, runtime_info
from ._commands import evaluate, help, rollout, run, simulate, sweep, train
from ._rollouts import DecodedFields, ReducedModel, RolloutBatch

__all__ = [
    "DecodedFields",
    "Error",
    "Outcome",
    "ReducedModel",
    "RolloutBatch",
    "RomSettings",
    "SimulationFailed",
    "__version__",
    "evaluate",
    "help",
    "initialize",
    "precision",
    "rollout",
    "run",
    "runtime_info",
    "simulate",
    "sweep",
    "train",
]
