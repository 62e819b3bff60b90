"""
Clear errors for damaged SB3 model files: :meth:`REINFORCE.load <sb3_reinforce.REINFORCE.load>` checks a file's
integrity before SB3 reads it.

SB3's ``.zip`` format stores some attributes with ``cloudpickle``: loading such a file runs whatever code its
author put in it. Only load ``.zip`` files you trust; :mod:`sb3_reinforce.reinforce.weights_only` is a format
that unpickles nothing.
"""

import io
import json
import pathlib
import zipfile
import zlib
from typing import IO

__all__ = ["CorruptModelFileError", "check_model_file"]


class CorruptModelFileError(ValueError):
    """A model file is truncated, corrupted, or not a model file at all."""


def check_model_file(path: str | pathlib.Path | io.BufferedIOBase | IO[bytes]) -> None:
    """
    Check that an SB3 model ``.zip`` is intact before SB3 reads it: a readable zip archive whose members
    pass their CRC checks, with a ``data`` member that is valid JSON and a ``policy.pth`` member.
    This checks integrity only: it does not make a file from an untrusted source safe to load.

    :param path: The file (``.zip`` is appended when the path does not exist, as SB3 does), or an open file
    :raises CorruptModelFileError: naming the file and what is wrong with it
    """
    if isinstance(path, (str, pathlib.Path)):
        path = pathlib.Path(path)
        if not path.exists() and path.with_name(path.name + ".zip").exists():
            path = path.with_name(path.name + ".zip")
        if not path.exists():
            return  # SB3 raises its own FileNotFoundError
        name = str(path)
    else:
        name = getattr(path, "name", repr(path))
        start = path.tell()
    try:
        with zipfile.ZipFile(path) as archive:
            damaged = archive.testzip()
            if damaged is not None:
                raise CorruptModelFileError(f"Cannot load {name}: member {damaged!r} fails its CRC check (corrupted file)")
            missing = [member for member in ("data", "policy.pth") if member not in archive.namelist()]
            if missing:
                raise CorruptModelFileError(
                    f"Cannot load {name}: the file is truncated or corrupted, or not an SB3 model file "
                    f"(it has no {missing} member)"
                )
            json.loads(archive.read("data").decode())
    except (zipfile.BadZipFile, zlib.error, EOFError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise CorruptModelFileError(
            f"Cannot load {name}: the file is truncated or corrupted ({type(exc).__name__}: {exc})"
        ) from exc
    finally:
        if not isinstance(path, pathlib.Path):
            path.seek(start)
