"""The program's commands in this process: keyword arguments become the command line's options."""

from __future__ import annotations

import json
import logging
import os
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Union

from . import _core

PathLike = Union[str, "os.PathLike[str]"]
Progress = Optional[Callable[[str], None]]

_log = logging.getLogger("mpmrom")


def _to_log(line: str) -> None:
    """Progress lines at INFO, the program's warnings at WARNING, on the logger "mpmrom"."""
    _log.log(logging.WARNING if "warning:" in line else logging.INFO, line)


def _options(options: Mapping[str, Any]) -> list[str]:
    """`name=value` as `--name value`: underscores become dashes, True a flag, a list several values, None nothing."""
    args: list[str] = []
    for name, value in options.items():
        if value is None or value is False:
            continue
        flag = "--" + name.replace("_", "-")
        if value is True:
            args.append(flag)
        elif isinstance(value, (list, tuple)):
            args.append(flag)
            args.extend(_text(v) for v in value)
        else:
            args.extend([flag, _text(value)])
    return args


def _text(value: Any) -> str:
    if isinstance(value, float):
        return repr(value)  # the shortest text that reads back to the same double
    return os.fspath(value) if isinstance(value, os.PathLike) else str(value)


def run(*args: Any, progress: Progress = None) -> str:
    """Runs `mpmrom ARGS...` in this process and returns what it printed on stdout.

    Lines it prints on stderr go to `progress(line)`, or to the logger "mpmrom" (INFO; warnings at WARNING).
    Raises `mpmrom.Error` (`mpmrom.SimulationFailed` for a failed simulation) with the program's one-line message.
    """
    return _core.run_command([_text(a) for a in args], progress if progress is not None else _to_log)


def help(command: str = "") -> str:
    """The command line's help for `command` (every option the keyword arguments mirror), or the program's."""
    return run(*([command] if command else []), "--help")


def _json(text: str) -> Any:
    return json.loads(text) if text.strip() else None


def simulate(scene: PathLike, out: PathLike, *, set: Union[Mapping[str, Any], Sequence[str], None] = None,
             progress: Progress = None, **options: Any) -> Path:
    """Runs the full-order model on a scene into one snapshot file (`mpmrom simulate`); returns its path.

    `set` overrides parameters or scene entries: {"rho": 1.2, "material.density": 500} or ["rho=1.2"].
    Other options as keywords (`p2g="scatter"`); `mpmrom.help("simulate")` lists them.
    """
    overrides = [f"{k}={_text(v)}" for k, v in set.items()] if isinstance(set, Mapping) else set
    run("simulate", scene, *_options({"out": out, "set": overrides, **options}), progress=progress)
    return Path(out)


def sweep(scene: PathLike, out: PathLike, *, progress: Progress = None, **options: Any) -> Path:
    """Runs every run of the scene's design into `out` (runs/*.h5, design.csv; `mpmrom sweep`); returns `out`.

    Options as keywords (`resume=True`, `p2g="scatter"`); `mpmrom.help("sweep")` lists them.
    """
    run("sweep", scene, *_options({"out": out, **options}), progress=progress)
    return Path(out)


def train(data: Union[PathLike, Sequence[PathLike]], out: PathLike, *, progress: Progress = None,
          **options: Any) -> Any:
    """Trains a deformation map on sweep directories or snapshot files (`mpmrom train`).

    Returns the model's path, or with `json=True` the training record. Options as keywords (`latent=5`,
    `width=48`, `epochs=300`, `scene="scenes/poke_cylinder.toml"`, `lambda_grad=...`); `mpmrom.help("train")`.
    """
    inputs = [data] if isinstance(data, (str, os.PathLike)) else list(data)
    text = run("train", *inputs, *_options({"out": out, **options}), progress=progress)
    return _json(text) if options.get("json") else Path(out)


def rollout(model: PathLike, scene: PathLike, out: PathLike, *, progress: Progress = None, **options: Any) -> Any:
    """Reduced rollouts of the scene's design or of a parameter file into a ROM file (`mpmrom rollout`).

    Returns the ROM file's path, or with `json=True` the benchmark record. Options as keywords (`samples=30`,
    `method="node"`, `params="p.csv"`); `mpmrom.help("rollout")` lists them.
    """
    text = run("rollout", model, scene, *_options({"out": out, **options}), progress=progress)
    return _json(text) if options.get("json") else Path(out)


def evaluate(rom: PathLike, references: Union[PathLike, Sequence[PathLike]], *, progress: Progress = None,
             **options: Any) -> Any:
    """The errors of a ROM file against full-order references (sweep directories or snapshot files), as a dict
    (`mpmrom evaluate --json`). Options as keywords (`model=...`); `mpmrom.help("evaluate")` lists them."""
    refs = [references] if isinstance(references, (str, os.PathLike)) else list(references)
    return _json(run("evaluate", rom, *refs, *_options({**options, "json": True}), progress=progress))
