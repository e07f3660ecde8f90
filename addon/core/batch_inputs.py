"""The motion files a batch takes: files and folders as a user names them, folders searched (recursively
unless told not to) for the formats MotionKit reads, filtered by a glob on the file's name. No bpy here."""
from __future__ import annotations

import fnmatch
import os
from collections.abc import Iterable

MOTION_EXTENSIONS = (".bvh", ".fbx", ".glb", ".gltf")


def collect(inputs: Iterable, pattern: str = "*", recursive: bool = True) -> list[str]:
    """The motion files named by inputs, each once, in a stable order: a file as given (whatever its name,
    so a bad one is reported rather than skipped), a folder's motion files whose names match pattern,
    sorted. FileNotFoundError names an input that does not exist."""
    found, seen = [], set()
    for item in inputs:
        path = os.path.abspath(os.fspath(item))
        if os.path.isdir(path):
            candidates = _folder_files(path, pattern, recursive)
        elif os.path.isfile(path):
            candidates = [path]
        else:
            raise FileNotFoundError(f"{item}: no such file or folder")
        for candidate in candidates:
            if candidate not in seen:
                seen.add(candidate)
                found.append(candidate)
    return found


def _folder_files(folder: str, pattern: str, recursive: bool) -> list[str]:
    files = []
    for root, dirs, names in os.walk(folder):
        dirs.sort()
        files += [os.path.join(root, n) for n in sorted(names)
                  if n.lower().endswith(MOTION_EXTENSIONS) and fnmatch.fnmatch(n, pattern)]
        if not recursive:
            break
    return files


def stems(files: list[str]) -> dict[str, str]:
    """Each file's name for its clips: its stem, or its whole name where several files of the batch share
    the stem (walk.fbx and walk.bvh), so that no clip or output takes another's name."""
    plain = {path: os.path.splitext(os.path.basename(path))[0] for path in files}
    counts: dict[str, int] = {}
    for stem in plain.values():
        counts[stem] = counts.get(stem, 0) + 1
    return {path: stem if counts[stem] == 1 else os.path.basename(path) for path, stem in plain.items()}


def clip_name(path: str, take: str | None = None, takes: int = 1, stem: str | None = None) -> str:
    """An action's name for a take of a file: the file's stem, with '|take' when the file holds several."""
    stem = stem or os.path.splitext(os.path.basename(path))[0]
    return f"{stem}|{take}" if take and takes > 1 else stem
