"""The model shipped to Dask workers as data (sim/sweep/model_bundle.py): the MJCF, its includes
and the asset files under the compiler's folders, compiled by MuJoCo from the bundle after the
client's files are gone."""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
import pytest

from gantry_sim.controller.errors import ConfigError
from gantry_sim.sim.sweep.model_bundle import bundle_model, materialized

TETRA_OBJ = "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0 0 0.1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n"
MAIN = """<!-- a comment with -- inside, as MuJoCo allows -->
<mujoco model="bundle test">
  <compiler meshdir="../assets/meshes" texturedir="../assets/tex"/>
  <include file="parts/assets.xml"/>
  <worldbody>
    <include file="parts/body.xml"/>
  </worldbody>
</mujoco>
"""
ASSETS = """<mujoco>
  <asset>
    <mesh name="tetra" file="tetra.obj"/>
    <texture name="wood" type="2d" file="wood.png"/>
    <material name="wood" texture="wood"/>
  </asset>
</mujoco>
"""
BODY = """<mujoco>
  <body name="b">
    <joint type="slide" axis="1 0 0"/>
    <geom type="mesh" mesh="tetra" material="wood" mass="1"/>
  </body>
</mujoco>
"""


def _write_model(root) -> None:
    import matplotlib.image

    (root / "models" / "parts").mkdir(parents=True)
    (root / "assets" / "meshes").mkdir(parents=True)
    (root / "assets" / "tex").mkdir(parents=True)
    (root / "models" / "robot.xml").write_text(MAIN)
    (root / "models" / "parts" / "assets.xml").write_text(ASSETS)
    (root / "models" / "parts" / "body.xml").write_text(BODY)
    (root / "assets" / "meshes" / "tetra.obj").write_text(TETRA_OBJ)
    matplotlib.image.imsave(root / "assets" / "tex" / "wood.png", np.zeros((4, 4, 3)))


def test_the_bundle_compiles_without_the_clients_files(tmp_path):
    mujoco = pytest.importorskip("mujoco")
    client = tmp_path / "client"
    _write_model(client)
    original = mujoco.MjModel.from_xml_path(str(client / "models" / "robot.xml"))
    bundle = bundle_model(str(client / "models" / "robot.xml"))
    assert [name for name, _ in bundle.files] == [
        "assets/meshes/tetra.obj",
        "assets/tex/wood.png",
        "models/parts/assets.xml",
        "models/parts/body.xml",
        "models/robot.xml",
    ]
    assert bundle.main == "models/robot.xml"
    shutil.rmtree(client)  # nothing of the client's is left to open
    with materialized(bundle) as path:
        shipped = mujoco.MjModel.from_xml_path(path)
    assert not Path(path).parent.parent.exists()  # the private folder went with the block
    assert (shipped.nmesh, shipped.ntex, shipped.nbody) == (1, 1, 2)
    assert np.array_equal(shipped.mesh_vert, original.mesh_vert)
    assert shipped.body_mass[1] == original.body_mass[1] == 1.0


def test_same_content_same_digest_other_content_another(tmp_path):
    _write_model(tmp_path / "a")
    _write_model(tmp_path / "b")
    a = bundle_model(str(tmp_path / "a" / "models" / "robot.xml"))
    b = bundle_model(str(tmp_path / "b" / "models" / "robot.xml"))
    assert a.digest == b.digest
    (tmp_path / "b" / "assets" / "meshes" / "tetra.obj").write_text(TETRA_OBJ + "\n")
    assert bundle_model(str(tmp_path / "b" / "models" / "robot.xml")).digest != a.digest


def test_missing_and_absolute_references_are_clear_errors(tmp_path):
    _write_model(tmp_path)
    (tmp_path / "assets" / "meshes" / "tetra.obj").unlink()
    with pytest.raises(
        ConfigError, match=r"cannot read '.*tetra.obj' \(referenced by .*assets.xml"
    ):
        bundle_model(str(tmp_path / "models" / "robot.xml"))
    (tmp_path / "models" / "parts" / "assets.xml").write_text(
        ASSETS.replace('file="tetra.obj"', f'file="{tmp_path}/tetra.obj"')
    )
    with pytest.raises(ConfigError, match="ships the model to its workers by relative paths"):
        bundle_model(str(tmp_path / "models" / "robot.xml"))
