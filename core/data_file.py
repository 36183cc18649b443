"""Data-only files: values made of numpy arrays, plain values and the dataclasses a caller names, written as one
.npz (numpy's zip of .npy arrays) and read back without running anything the file holds.

A file has three kinds of members: ``header`` (JSON: the format's name and version, and whatever the caller
wants to read without the rest, such as a cache's key), ``content`` (JSON: the value's tree) and ``array_<i>``
(.npy arrays, read with ``allow_pickle=False``, so no object array, which only pickle could restore, is read).
In the tree, arrays and numpy scalars are {"array": i} and {"scalar": i}; a list, tuple, set or dict is
{"list": [...]}, {"tuple": [...]}, {"set": [...]} or {"dict": [[key, value], ...]}; an instance of one of the
caller's classes is {"object": name, "fields": {...}} (its attributes), or {"object": name, "state": ...} for a
class that defines ``__setstate__`` (what it gives to pickle, as core.raycast.RayCaster gives its triangles); a
value met again (the same object or array referred to twice) is {"ref": i}, so that shared parts stay shared and
cycles close. On reading, an object
is made by ``cls.__new__`` of a class from the caller's list only, given its attributes (plain names, no dunder)
or its state: a file that names any other type is refused, so a crafted file can only hold wrong numbers, never
code.
"""
from __future__ import annotations

import json
import zipfile

import numpy as np

from .errors import SceneError

HEADER, CONTENT = "header", "content"


def data_writer(header: dict, content, classes):
    """A writer, for core.staged_files.StagedFiles.stage, of ``content`` (built of arrays, plain values and
    instances of ``classes``) with the JSON-ready ``header`` (it holds "format" and "version")."""
    def write(temporary: str) -> None:
        arrays: list = []
        tree = _Encoder(_class_names(classes), arrays).encode(content)
        members = {HEADER: _json_bytes(header), CONTENT: _json_bytes(tree)}
        members.update({f"array_{i}": array for i, array in enumerate(arrays)})
        with open(temporary, "wb") as file:  # a file object: np.savez would add .npz to a path
            np.savez(file, **members)
    return write


def read_header(path: str, format_name: str, version: int, what: str) -> dict:
    """The header of the data file at ``path``, after checking its format and version; SceneError names the file
    (and ``what`` it should be) if it is missing, unreadable, truncated, or of another format or version."""
    with _opened(path, what) as members:
        return _checked_header(members, path, format_name, version, what)


def read_data(path: str, format_name: str, version: int, what: str, classes) -> tuple[dict, object]:
    """(header, content) of the data file at ``path`` (``read_header``'s checks), its objects made only of
    ``classes``; SceneError names the file if its content names another type or is damaged."""
    with _opened(path, what) as members:
        header = _checked_header(members, path, format_name, version, what)
        try:
            tree = json.loads(bytes(members[CONTENT]).decode("utf-8"))
            return header, _Decoder(_class_names(classes), members).decode(tree)
        except (KeyError, TypeError, ValueError, AttributeError, IndexError, zipfile.BadZipFile, OSError) as error:
            raise SceneError(f"'{path}' is not a {what} that this baker can read ({error}).") from error


class _opened:
    """The npz members at ``path``, opened with allow_pickle=False, as a context; SceneError names the file."""

    def __init__(self, path: str, what: str):
        self.path, self.what = path, what

    def __enter__(self):
        try:
            self.members = np.load(self.path, allow_pickle=False)
        except OSError as error:
            raise SceneError(f"Cannot read the {self.what} '{self.path}': {error.strerror or error}.") from error
        except (ValueError, EOFError, zipfile.BadZipFile) as error:
            raise SceneError(f"'{self.path}' is not a {self.what} (or it is truncated).") from error
        if not isinstance(self.members, np.lib.npyio.NpzFile):
            raise SceneError(f"'{self.path}' is not a {self.what}.")
        return self.members

    def __exit__(self, *exc) -> None:
        self.members.close()


def _checked_header(members, path: str, format_name: str, version: int, what: str) -> dict:
    try:
        header = json.loads(bytes(members[HEADER]).decode("utf-8"))
    except (KeyError, ValueError, zipfile.BadZipFile, OSError) as error:
        raise SceneError(f"'{path}' is not a {what} (or it is truncated).") from error
    if not isinstance(header, dict) or header.get("format") != format_name:
        raise SceneError(f"'{path}' is not a {what}.")
    if header.get("version") != version:
        raise SceneError(f"'{path}' is a {what} of format version {header.get('version')}; this baker reads "
                         f"version {version}. Bake the scene again.")
    return header


def _json_bytes(value) -> np.ndarray:
    return np.frombuffer(json.dumps(value).encode("utf-8"), dtype=np.uint8)


def _class_names(classes) -> dict:
    names = {cls.__qualname__: cls for cls in classes}
    if len(names) != len(classes):
        raise ValueError("Two data-file classes share a name.")
    return names


def _custom_state(cls) -> bool:
    return hasattr(cls, "__setstate__")


class _Encoder:
    def __init__(self, classes: dict, arrays: list):
        self.names = {cls: name for name, cls in classes.items()}
        self.arrays, self.seen, self.keep = arrays, {}, []

    def encode(self, value):
        if value is None or isinstance(value, (bool, int, float, str)) and not isinstance(value, np.generic):
            return value
        if id(value) in self.seen:
            return {"ref": self.seen[id(value)]}
        self.seen[id(value)] = len(self.seen)
        self.keep.append(value)  # alive until the end, so that no id is reused by another value
        if isinstance(value, (np.ndarray, np.generic)):
            if np.asarray(value).dtype.hasobject:
                raise TypeError("An array of Python objects cannot be written to a data file.")
            self.arrays.append(np.asarray(value))
            return {"array" if isinstance(value, np.ndarray) else "scalar": len(self.arrays) - 1}
        if isinstance(value, (list, tuple, set, frozenset)):
            kind = "list" if isinstance(value, list) else "tuple" if isinstance(value, tuple) else "set"
            return {kind: [self.encode(item) for item in value]}
        if isinstance(value, dict):
            return {"dict": [[self.encode(key), self.encode(item)] for key, item in value.items()]}
        cls = type(value)
        if cls not in self.names:
            raise TypeError(f"A {cls.__qualname__} is not among the types of this data file.")
        if _custom_state(cls):
            return {"object": self.names[cls], "state": self.encode(value.__getstate__())}
        return {"object": self.names[cls], "fields": {key: self.encode(item) for key, item in vars(value).items()}}


class _Decoder:
    def __init__(self, classes: dict, members):
        self.classes, self.members, self.made = classes, members, {}

    def decode(self, tree):
        if tree is None or isinstance(tree, (bool, int, float, str)):
            return tree
        if not isinstance(tree, dict) or len(tree) not in (1, 2):
            raise ValueError("damaged content")
        if "ref" in tree:
            return self.made[tree["ref"]]
        index = len(self.made)
        self.made[index] = None  # numbered in the order they were written
        if "array" in tree or "scalar" in tree:
            array = self.members[f"array_{int(tree.get('array', tree.get('scalar')))}"]
            value = array if "array" in tree else array[()]
        elif "list" in tree:
            value = []
            self.made[index] = value  # before its items, which may refer back to it
            value.extend(self.decode(item) for item in tree["list"])
        elif "tuple" in tree:
            value = tuple(self.decode(item) for item in tree["tuple"])
        elif "set" in tree:
            value = set(self.decode(item) for item in tree["set"])
        elif "dict" in tree:
            value = {self.decode(key): self.decode(item) for key, item in tree["dict"]}
        elif "object" in tree:
            return self._object(index, tree)
        else:
            raise ValueError("damaged content")
        self.made[index] = value
        return value

    def _object(self, index: int, tree: dict):
        name = tree["object"]
        if name not in self.classes:
            raise ValueError(f"it names the type '{name}', which is not among its types")
        cls = self.classes[name]
        value = cls.__new__(cls)
        self.made[index] = value  # before its parts, which may refer back to it
        if "state" in tree and _custom_state(cls):
            value.__setstate__(self.decode(tree["state"]))
        elif "fields" in tree and isinstance(tree["fields"], dict):
            for key, item in tree["fields"].items():
                if not key.isidentifier() or key.startswith("__"):
                    raise ValueError(f"it sets the attribute '{key}'")
                object.__setattr__(value, key, self.decode(item))  # frozen dataclasses too
        else:
            raise ValueError("damaged content")
        return value

