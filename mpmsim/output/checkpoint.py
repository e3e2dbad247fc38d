"""Checkpoints: the whole run state in one `.npz` file, so a stopped or killed run continues
where the checkpoint was taken and ends bit for bit as the uninterrupted run would.

What is saved is found by walking the run object (mpmsim.solver.Simulation): the state, the
integrator (its warm starts and lagged data), the stability check, the history rows, the VTU
series' list of frames and the run loop's schedule. Every numpy array and every number,
string, list, tuple and dict reached through mpmsim's own objects is saved; what the deck
determines (the scene: bodies, grid, materials) and functions are not, so a restart builds
the scene from the same deck and pours the saved values into it.

Format (`<stem>_checkpoint.npz`, numpy's zip of .npy files, read with allow_pickle=False):
- `manifest`: a JSON document (a 0-d unicode array):
  {"format": "mpmsim-checkpoint", "version": 1, "mpmsim": <version>, "deck": <sha256 of
  the validated deck>, "t": ..., "step": ..., "threads": ..., "tree": <node>}
- `a0`, `a1`, ...: the arrays the tree's nodes name.
A node is {"t": kind, ...}: none, bool, int, float (hex, exact), np (a numpy scalar), str,
array (key), ref (the path of an object seen earlier: shared arrays stay shared), list,
tuple, rows (a list of equal-length numeric rows as one array), dict, obj (a class of
mpmsim and its attributes), nt (a named tuple), method (a bound method's object).
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import types
from pathlib import Path

import numpy as np

from ..deck.loader import deck_digest  # noqa: F401  (the digest a checkpoint records)
from .atomic import atomic_path

FORMAT = "mpmsim-checkpoint"
VERSION = 1
SKIP_ATTRS = frozenset({"scene", "loaded", "deck"})  # built from the deck again on restart


class CheckpointError(Exception):
    """A checkpoint that cannot be used: missing, unreadable, or from another deck or version."""


def checkpoint_path(directory: Path, stem: str) -> Path:
    return Path(directory) / f"{stem}_checkpoint.npz"


def _is_own(obj) -> bool:
    return type(obj).__module__.startswith("mpmsim.")


def _class_name(obj) -> str:
    return f"{type(obj).__module__}:{type(obj).__qualname__}"


def _resolve_class(name: str):
    module, _, qual = name.partition(":")
    if not module.startswith("mpmsim."):
        raise CheckpointError(f"class {name!r} is not one of mpmsim's")
    cls = importlib.import_module(module)
    for part in qual.split("."):
        cls = getattr(cls, part)
    return cls


def _skipped(value) -> bool:
    """Values a restart takes from the freshly built run, not from the checkpoint: paths (the
    folder may have moved), functions, and objects that are not mpmsim's (numba dispatchers)."""
    if isinstance(value, Path):
        return True
    if isinstance(value, (list, tuple)) and value and all(isinstance(v, Path) for v in value):
        return True
    if isinstance(value, (types.FunctionType, types.BuiltinFunctionType, types.ModuleType, type)):
        return True
    return False


class _Encoder:
    def __init__(self):
        self.arrays: dict[str, np.ndarray] = {}
        self.seen: dict[int, str] = {}

    def array(self, a: np.ndarray) -> dict:
        if a.dtype.hasobject:
            raise CheckpointError("an object array cannot be checkpointed")
        key = f"a{len(self.arrays)}"
        self.arrays[key] = a
        return {"t": "array", "k": key}

    def node(self, value, path: str):
        if value is None:
            return {"t": "none"}
        if getattr(type(value), "checkpoint_skip", False):  # (device copies: the host state is saved)
            return None
        if isinstance(value, bool):
            return {"t": "bool", "v": value}
        if isinstance(value, np.generic):
            v = value.item()
            return {"t": "np", "d": value.dtype.str, "v": float(v).hex() if isinstance(v, float) else v}
        if isinstance(value, int):
            return {"t": "int", "v": value}
        if isinstance(value, float):
            return {"t": "float", "v": value.hex()}
        if isinstance(value, str):
            return {"t": "str", "v": value}
        if id(value) in self.seen:
            return {"t": "ref", "p": self.seen[id(value)]}
        if isinstance(value, np.ndarray):
            self.seen[id(value)] = path
            return self.array(value)
        if isinstance(value, tuple) and hasattr(value, "_fields"):
            if not _is_own(value):
                return None
            return {"t": "nt", "cls": _class_name(value),
                    "v": [self.node(v, f"{path}[{i}]") for i, v in enumerate(value)]}
        if isinstance(value, (list, tuple)):
            rows = self.rows(value)
            if rows is not None:
                return rows
            if isinstance(value, list):
                self.seen[id(value)] = path
            items = [self.node(v, f"{path}[{i}]") for i, v in enumerate(value)]
            return {"t": "list" if isinstance(value, list) else "tuple", "v": items}
        if isinstance(value, dict):
            self.seen[id(value)] = path
            pairs = []
            for k, v in value.items():
                if _skipped(v):
                    continue
                item = self.node(v, f"{path}[{k!r}]")
                if item is not None:
                    pairs.append([self.node(k, path), item])
            return {"t": "dict", "v": pairs}
        if isinstance(value, types.MethodType):
            return {"t": "method", "self": self.node(value.__self__, f"{path}.__self__")} \
                if _is_own(value.__self__) else None
        if _is_own(value) and hasattr(value, "__dict__"):
            self.seen[id(value)] = path
            attrs = {}
            for k, v in vars(value).items():
                if k in SKIP_ATTRS or _skipped(v):
                    continue
                item = self.node(v, f"{path}.{k}")
                if item is not None:
                    attrs[k] = item
            return {"t": "obj", "cls": _class_name(value), "v": attrs}
        return None  # not mpmsim's (numba dispatchers, rich objects): built again on restart

    def rows(self, value) -> dict | None:
        """A list of at least two equal-length rows of plain numbers (history rows, per-step
        statistics) as one float array; ints are marked per column."""
        if not isinstance(value, list) or len(value) < 2:
            return None
        first = value[0]
        if not isinstance(first, (list, tuple)) or hasattr(first, "_fields") or not first:
            return None
        n, kind = len(first), type(first)
        number = (int, float, np.floating, np.integer)
        for r in value:
            if type(r) is not kind or len(r) != n or not all(isinstance(v, number) and not isinstance(v, bool)
                                                             for v in r):
                return None
        ints = [all(isinstance(r[j], (int, np.integer)) for r in value) for j in range(n)]
        data = np.array([[float(v) for v in r] for r in value], dtype=np.float64)
        if any(ints) and np.abs(data[:, ints]).max() >= 2.0 ** 53:
            return None
        return {"t": "rows", "k": self.array(data)["k"], "inner": "list" if kind is list else "tuple", "ints": ints}


class _Decoder:
    def __init__(self, arrays):
        self.arrays = arrays
        self.done: dict[str, object] = {}  # path -> restored object (targets of refs)
        self.claimed: dict[int, str] = {}  # id of a fresh object -> the path it was restored as

    def claim(self, obj, path: str):
        self.done[path] = obj
        self.claimed.setdefault(id(obj), path)
        return obj

    def free(self, target, path: str) -> bool:
        """Whether the fresh object may take this path's values in place (not already taken by
        another path: objects shared in the fresh run but not in the checkpoint get copies)."""
        return target is not None and self.claimed.get(id(target), path) == path

    def value(self, node: dict | None, target, path: str):
        if node is None:  # not saved (a function or a foreign object in a list): the fresh one stays
            return target
        t = node["t"]
        if t == "none":
            return None
        if t in ("bool", "int", "str"):
            return node["v"]
        if t == "float":
            return float.fromhex(node["v"])
        if t == "np":
            v = node["v"]
            return np.dtype(node["d"]).type(float.fromhex(v) if isinstance(v, str) else v)
        if t == "ref":
            if node["p"] not in self.done:
                raise CheckpointError(f"{path}: refers to {node['p']}, which is not restored")
            return self.done[node["p"]]
        if t == "array":
            a = self.arrays[node["k"]]
            if (isinstance(target, np.ndarray) and self.free(target, path) and target.shape == a.shape
                    and target.dtype == a.dtype and target.flags.writeable):
                target[...] = a
                return self.claim(target, path)
            return self.claim(np.array(a), path)
        if t == "rows":
            data = self.arrays[node["k"]]
            inner = list if node["inner"] == "list" else tuple
            ints = node["ints"]
            return [inner(int(v) if ints[j] else float(v) for j, v in enumerate(r)) for r in data.tolist()]
        if t in ("list", "tuple"):
            same = isinstance(target, (list, tuple)) and len(target) == len(node["v"])
            items = [self.value(n, target[i] if same else None, f"{path}[{i}]") for i, n in enumerate(node["v"])]
            if t == "tuple":
                return tuple(items)
            if isinstance(target, list) and self.free(target, path):
                target[:] = items
                return self.claim(target, path)
            return self.claim(items, path)
        if t == "nt":
            cls = _resolve_class(node["cls"])
            same = isinstance(target, cls)
            return cls(*[self.value(n, target[i] if same else None, f"{path}[{i}]") for i, n in enumerate(node["v"])])
        if t == "dict":
            own = target if isinstance(target, dict) and self.free(target, path) else {}
            self.claim(own, path)
            new = {}
            for kn, vn in node["v"]:
                k = self.value(kn, None, path)
                new[k] = self.value(vn, own.get(k), f"{path}[{k!r}]")
            own.update(new)
            return own
        if t == "method":
            if isinstance(target, types.MethodType):
                self.value(node["self"], target.__self__, f"{path}.__self__")
            return target
        if t == "obj":
            cls = _resolve_class(node["cls"])
            obj = target if type(target) is cls and self.free(target, path) else cls.__new__(cls)
            self.claim(obj, path)
            for k, n in node["v"].items():
                cur = obj.__dict__.get(k)
                new = self.value(n, cur, f"{path}.{k}")
                if new is not cur:
                    object.__setattr__(obj, k, new)
            return obj
        raise CheckpointError(f"{path}: unknown node kind {t!r}")


def write_checkpoint(path: Path, root: dict, meta: dict) -> None:
    """Save `root` ({name: object}) with `meta` (JSON-able) atomically: a temporary file beside
    `path`, flushed to disk, then renamed over it."""
    enc = _Encoder()
    tree = {name: enc.node(obj, name) for name, obj in root.items()}
    manifest = {"format": FORMAT, "version": VERSION, **meta, "tree": tree}
    arrays = dict(enc.arrays)
    arrays["manifest"] = np.array(json.dumps(manifest))
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)
            fh.flush()
            os.fsync(fh.fileno())


def read_manifest(path: Path) -> dict:
    """The manifest of a checkpoint (CheckpointError when the file is not one)."""
    try:
        with np.load(path, allow_pickle=False) as z:
            manifest = json.loads(str(z["manifest"]))
    except FileNotFoundError:
        raise CheckpointError(f"no checkpoint {str(path)!r}") from None
    except (OSError, ValueError, KeyError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"{str(path)!r} is not a readable checkpoint ({exc})") from None
    if manifest.get("format") != FORMAT or manifest.get("version") != VERSION:
        raise CheckpointError(f"{str(path)!r} is not an mpmsim checkpoint of format version {VERSION}")
    return manifest


def restore_checkpoint(path: Path, root: dict, manifest: dict | None = None) -> dict:
    """Pour a checkpoint into the freshly built objects of `root` ({name: object}, the same
    names as when written); returns the manifest (`manifest`: the file's, already read)."""
    manifest = manifest if manifest is not None else read_manifest(path)
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k != "manifest"}
    dec = _Decoder(arrays)
    for name, obj in root.items():
        node = manifest["tree"].get(name)
        if node is None:
            raise CheckpointError(f"{str(path)!r} holds no {name!r}")
        dec.value(node, obj, name)
    return manifest
