"""The MJCF model as data, for workers that do not share the client's files (``--executor dask``).

:func:`bundle_model` reads, on the client, the model file and every file it references: the
``<include file>``s (recursively; relative to the main model's folder, as MuJoCo resolves them)
and the asset files (``file``/``fileright``/... of mesh, skin, texture, hfield, relative to
``<compiler meshdir/texturedir/assetdir>``). :func:`materialized` writes them, on a worker, under
one private folder with the same relative layout and returns the main file's path there; the
worker never opens a path of the client's. Machine files need nothing of this: a
:class:`MachineConfig` travels as a value, only its ``[sim] model`` is a path.
"""

from __future__ import annotations

import hashlib
import os
import re
import tempfile
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

from gantry_sim.controller.config import MachineConfig
from gantry_sim.controller.errors import ConfigError
from gantry_sim.controller.input_files import check_model_file

#: attributes naming a file; the cube-texture faces included
FILE_ATTRS = ("file", "fileright", "fileleft", "fileup", "filedown", "filefront", "fileback")
#: most bytes shipped with a model (meshes included) [B]
MAX_BUNDLE_BYTES = 256 * 2**20
_COMMENT = re.compile(rb"<!--.*?-->", re.DOTALL)


@dataclass(frozen=True)
class ModelBundle:
    """The model's files as bytes: ``main`` and each of ``files`` by a '/'-separated path
    relative to the folder that holds them all; ``digest`` identifies the content."""

    main: str
    files: tuple[tuple[str, bytes], ...]
    digest: str


def _asset_dir(tag: str, dirs: dict[str, str]) -> str:
    if tag in ("mesh", "skin"):
        return dirs.get("meshdir") or dirs.get("assetdir", "")
    if tag in ("texture", "hfield"):
        return dirs.get("texturedir") or dirs.get("assetdir", "")
    return ""


def _read(path: Path, by: Path) -> bytes:
    what = "the MJCF model" if path == by else f"'{path}' (referenced by {by})"
    check_model_file(path, what)
    try:
        return path.read_bytes()
    except OSError as exc:
        raise ConfigError(
            f"cannot read {what} to ship it to the workers: {exc.strerror}", file=str(by)
        ) from None


def _references(xml: Path, root: Path, dirs: dict[str, str], found: dict[Path, bytes]) -> None:
    """Add ``xml`` and what it references (recursively) to ``found`` (path -> bytes)."""
    data = found.setdefault(xml, _read(xml, xml))
    try:  # comments dropped first: MuJoCo's parser accepts "--" inside them, ElementTree not
        tree = ET.fromstring(_COMMENT.sub(b"", data))
    except ET.ParseError as exc:
        raise ConfigError(f"cannot load the MJCF model: {exc}", file=str(xml)) from None
    for el in tree.iter("compiler"):
        dirs.update(
            {k: el.get(k, "") for k in ("meshdir", "texturedir", "assetdir") if k in el.attrib}
        )
    for el in tree.iter():
        for attr in FILE_ATTRS:
            name = el.get(attr)
            if not name:
                continue
            if os.path.isabs(name):
                raise ConfigError(
                    f'<{el.tag} {attr}="{name}">: the dask executor ships the model to its '
                    "workers by relative paths; give the path relative to the model's folder",
                    file=str(xml),
                )
            if el.tag == "include":
                inc = (root / name).resolve()
                if inc not in found:
                    _references(inc, root, dirs, found)
            else:
                path = (root / _asset_dir(el.tag, dirs) / name).resolve()
                found.setdefault(path, _read(path, xml))


def bundle_model(model_path: str) -> ModelBundle:
    """Read the MJCF at ``model_path`` and the files it references (see the module doc)."""
    main = Path(model_path).resolve()
    found: dict[Path, bytes] = {}
    _references(main, main.parent, {}, found)
    base = Path(os.path.commonpath([p.parent for p in found]))
    files = tuple(sorted((p.relative_to(base).as_posix(), b) for p, b in found.items()))
    size = sum(len(b) for _, b in files)
    if size > MAX_BUNDLE_BYTES:
        raise ConfigError(
            f"the model and its files take {size / 2**20:.0f} MB, beyond the "
            f"{MAX_BUNDLE_BYTES // 2**20} MB shipped to dask workers",
            file=str(main),
        )
    digest = hashlib.sha256()
    for rel, b in files:
        digest.update(rel.encode() + b"\0" + hashlib.sha256(b).digest())
    return ModelBundle(main.relative_to(base).as_posix(), files, digest.hexdigest()[:16])


@contextmanager
def materialized(bundle: ModelBundle) -> Iterator[str]:
    """Write ``bundle`` into a private temporary folder and yield the absolute path of its main
    MJCF file; the folder is removed when the block ends (a grid point's run: the model is read
    when the run loads it). Per point, not per process: a Dask worker is stopped without
    running ``atexit``, which left a folder behind in $TMPDIR per worker and sweep."""
    with tempfile.TemporaryDirectory(prefix=f"gantry-model-{bundle.digest}-") as tmp:
        folder = Path(tmp)
        for rel, data in bundle.files:
            path = folder.joinpath(*rel.split("/"))
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_bytes(data)
        yield str(folder.joinpath(*bundle.main.split("/")))


def with_model(machine: MachineConfig, model: str) -> MachineConfig:
    """``machine`` with its ``[sim] model`` at ``model`` (a path of this host)."""
    return replace(machine, sim=replace(machine.sim, model=model))
