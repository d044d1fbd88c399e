"""Units of work: tasks, blocks of points and their shards on disk.

A step's work is a list of :class:`Task` objects, each a function call on a worker. A task
whose tag is a :class:`Block` (a run of consecutive points of a grid or a basin, in C order)
is resumable: its result is saved atomically as a shard::

    <out>/.<step>.parts/<step key>/b000012.npz

and a rerun skips the blocks whose shard exists. The step key (a hash of everything the
step's dataset depends on) names the folder, so shards of other settings are never reused.
"""
from __future__ import annotations

import os
import shutil
import uuid
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from .errors import RunFailed


@dataclass(frozen=True)
class Block:
    """Consecutive points (flat C-order indices ``lo..hi``) of a step's point set."""

    index: int
    lo: int
    hi: int

    @property
    def id(self) -> str:
        return f"b{self.index:06d}"

    @property
    def size(self) -> int:
        return self.hi - self.lo


@dataclass
class Task:
    """One call ``fn(*args, **kwargs)`` on a worker (an importable function, picklable
    arguments). ``tag`` names its result: a :class:`Block` is saved as a shard (resumable),
    anything else is kept in memory until the step finishes. An ``exclusive`` task runs alone
    on the pool (it measures wall time). ``units``: how much of its step's progress count it
    is (the runner sets a block's: one, or its points when its kind counts points)."""

    tag: Any
    fn: Callable
    args: tuple
    kwargs: dict = field(default_factory=dict)
    exclusive: bool = False
    units: int = 1


def make_blocks(n_points: int, block_size: int) -> list[Block]:
    """``n_points`` in runs of ``block_size`` (the last may be shorter)."""
    return [Block(i, lo, min(lo + block_size, n_points))
            for i, lo in enumerate(range(0, n_points, block_size))]


def parts_root(out: Path, step_name: str) -> Path:
    return out / f".{step_name}.parts"


def shard_dir(out: Path, step_name: str, key: str) -> Path:
    """The shard folder of a step run with key ``key``."""
    return parts_root(out, step_name) / key[:16]


def shard_path(folder: Path, block: Block) -> Path:
    return folder / f"{block.id}.npz"


def saved_blocks(folder: Path, blocks: Sequence[Block]) -> set[int]:
    """Indices of the blocks whose shard exists in ``folder``."""
    if not folder.is_dir():
        return set()
    names = {p.name for p in folder.iterdir()}
    return {b.index for b in blocks if f"{b.id}.npz" in names}


def write_shard(folder: Path, block: Block, arrays: dict[str, np.ndarray]) -> Path:
    """Save a block's arrays atomically (temp file in the same folder, fsync, os.replace)."""
    folder.mkdir(parents=True, exist_ok=True)
    final = shard_path(folder, block)
    tmp = folder / f".{block.id}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, lo=np.int64(block.lo), hi=np.int64(block.hi), **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return final


def read_shard(folder: Path, block: Block) -> dict[str, np.ndarray]:
    """A block's arrays from its shard; :class:`RunFailed` if the shard holds other points."""
    path = shard_path(folder, block)
    with np.load(path) as z:
        arrays = {k: z[k] for k in z.files if k not in ("lo", "hi")}
        if int(z["lo"]) != block.lo or int(z["hi"]) != block.hi or \
                any(len(v) != block.size for v in arrays.values()):
            raise RunFailed(f"shard {path} does not hold block {block.lo}..{block.hi}")
    return arrays


def clean_parts(out: Path, step_name: str, keep_key: str | None) -> None:
    """Remove stale shard folders (other step keys) and leftover temporary files; with
    ``keep_key=None`` every shard of the step."""
    root = parts_root(out, step_name)
    if not root.is_dir():
        return
    for p in root.iterdir():
        if keep_key is not None and p.name == keep_key[:16] and p.is_dir():
            for t in p.glob(".*.tmp"):
                t.unlink(missing_ok=True)
        elif p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    if keep_key is None:
        shutil.rmtree(root, ignore_errors=True)
