"""``--executor dask`` against a real ``dask scheduler`` and ``dask worker`` on 127.0.0.1
(issue 14): the model and its included files travel as data (a worker that cannot see the
client's model folder simulates the same numbers), and a worker without gantry-sim, or with
another version, is a clear exit-2 message within seconds instead of a hung client."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from importlib.metadata import version
from pathlib import Path

import pytest
from fault_helpers import TRACEBACK

from gantry_sim.controller.config import load_machine_config
from gantry_sim.models import DEFAULT_MACHINE
from gantry_sim.sim.cli import main
from gantry_sim.sim.sweep import executors
from gantry_sim.sim.sweep.grid import grid, run_sweep

pytest.importorskip("dask.distributed")
pytestmark = pytest.mark.slow  # each test starts a scheduler and a worker: a few seconds

TINY = "G21 G90 G17\nG0 X3 Y0\nG3 I-3 J0 F2400\nM2\n"
MODELS = Path(DEFAULT_MACHINE).parent


def _can_hide_folders() -> bool:
    """A user+mount namespace (unshare -rm) lets a worker run with a folder hidden."""
    if not shutil.which("unshare"):
        return False
    probe = subprocess.run(["unshare", "-rm", "true"], capture_output=True, timeout=10)
    return probe.returncode == 0


def _stop(proc: subprocess.Popen) -> None:
    if proc.poll() is None:
        os.killpg(proc.pid, signal.SIGKILL)  # its whole group: the worker under unshare too
    proc.wait(timeout=10)


@pytest.fixture
def scheduler(tmp_path) -> Iterator[str]:
    """A real scheduler on 127.0.0.1 (random free port); its address."""
    info = tmp_path / "scheduler.json"
    cmd = [sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1"]
    proc = subprocess.Popen(
        [*cmd, "--port", "0", "--no-dashboard", "--scheduler-file", str(info)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        deadline = time.monotonic() + 30
        while not info.exists() and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        time.sleep(0.1)  # the file is written whole, but let it be closed
        assert info.exists(), "the scheduler did not start"
        yield json.loads(info.read_text())["address"]
    finally:
        _stop(proc)


@pytest.fixture
def start_worker(tmp_path) -> Iterator:
    """start_worker(address, cwd, env=None, prefix=()) starts a one-thread worker subprocess
    (killed at teardown), ``prefix`` before its Python (e.g. unshare ...)."""
    procs: list[subprocess.Popen] = []

    def start(address: str, cwd: Path, env=None, prefix=(), python=(sys.executable,)) -> None:
        cmd = [*prefix, *python, "-m", "distributed.cli.dask_worker", address]
        cmd += ["--host", "127.0.0.1", "--nthreads", "1", "--no-nanny", "--no-dashboard"]
        cmd += ["--local-directory", str(tmp_path / f"worker{len(procs)}")]
        procs.append(
            subprocess.Popen(
                cmd,
                cwd=cwd,
                env=env,
                stdout=subprocess.DEVNULL,
                stderr=subprocess.DEVNULL,
                start_new_session=True,
            )
        )

    try:
        yield start
    finally:
        for proc in procs:
            _stop(proc)


@pytest.mark.skipif(not _can_hide_folders(), reason="needs unshare -rm (user+mount namespace)")
def test_the_model_goes_as_data_to_a_worker_that_cannot_see_it(
    tmp_path, scheduler, start_worker, capsys
):
    # the client's files: a machine file whose model includes another file
    client = tmp_path / "client"
    (client / "model").mkdir(parents=True)
    for name in ("scene.xml", "gantry.xml"):  # scene.xml: <include file="gantry.xml"/>
        shutil.copy(MODELS / name, client / "model" / name)
    machine_file = client / "my_machine.toml"
    machine_file.write_text('[sim]\nmodel = "model/scene.xml"\n')
    prog = client / "p.ngc"
    prog.write_text(TINY)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    # the worker runs elsewhere with the client's folder hidden under an empty tmpfs
    hide = ["unshare", "-rm", "sh", "-c", f'mount -t tmpfs none "{client}" && exec "$@"', "sh"]
    worker_tmp = tmp_path / "worker_tmp"
    worker_tmp.mkdir()
    start_worker(scheduler, elsewhere, env=dict(os.environ, TMPDIR=str(worker_tmp)), prefix=hide)

    out = tmp_path / "out"
    argv = ["sweep", str(prog), "--feed-override", "100,150", "--machine", str(machine_file)]
    status = main([*argv, "--executor", "dask", "--scheduler", scheduler, "--out", str(out)])
    cap = capsys.readouterr()
    assert status == 0, cap.err
    lines = cap.out.splitlines()
    assert len(lines) == 3 and all(x.endswith(",ok") for x in lines[1:]), cap.out
    # the model's files were written for each point and removed after it, not left to an
    # atexit that a stopped worker never runs
    assert sorted(p.name for p in worker_tmp.iterdir()) == []

    machine = load_machine_config(DEFAULT_MACHINE, machine_file)
    local = run_sweep(TINY, grid([100.0, 150.0]), machine, file=str(prog), workers=1)
    assert (out / "sweep.csv").read_text() == cap.out  # the CSV as printed
    for line, row in zip(lines[1:], local, strict=True):  # the same numbers as on this host
        assert line.split(",")[3] == repr(row["cycle_time_s"])
        assert line.split(",")[4] == repr(row["max_error_um"])


NO_GANTRY_SIM = """import sys


class _NoGantrySim:
    def find_spec(self, name, path=None, target=None):
        if name == "gantry_sim" or name.startswith("gantry_sim."):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


sys.meta_path.insert(0, _NoGantrySim())
"""


def test_a_worker_without_gantry_sim_is_a_clear_error_not_a_hang(
    tmp_path, scheduler, start_worker, capsys
):
    # A Python where Dask imports and gantry_sim does not, however gantry-sim is installed
    # (editable or not): a sitecustomize on the worker's path refuses the package's import.
    blocker = tmp_path / "no_gantry_sim"
    blocker.mkdir()
    (blocker / "sitecustomize.py").write_text(NO_GANTRY_SIM)
    env = dict(os.environ, PYTHONPATH=str(blocker))
    probe = subprocess.run(
        [sys.executable, "-c", "import distributed; import gantry_sim.sim"],
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert "No module named 'gantry_sim'" in probe.stderr  # the environment we mean
    start_worker(scheduler, tmp_path, env=env)
    prog = tmp_path / "p.ngc"
    prog.write_text(TINY)
    t0 = time.monotonic()
    status = main(["sweep", str(prog), "--executor", "dask", "--scheduler", scheduler])
    took_s = time.monotonic() - t0
    err = capsys.readouterr().err
    assert status == 2, err
    assert took_s < 20
    assert err.startswith("--scheduler: error: Dask worker(s) tcp://127.0.0.1:")
    assert f"of the scheduler at {scheduler} cannot run gantry-sim" in err
    assert "ModuleNotFoundError" in err and "No module named 'gantry_sim'" in err
    assert f"install gantry-sim {version('gantry-sim')} in the workers'" in err
    assert TRACEBACK not in err


def test_a_worker_with_another_gantry_sim_version_is_refused(
    tmp_path, scheduler, start_worker, capsys
):
    # the same code, but the worker's installed metadata says 0.0.1 (found first on its path)
    meta = tmp_path / "old" / "gantry_sim-0.0.1.dist-info"
    meta.mkdir(parents=True)
    (meta / "METADATA").write_text("Metadata-Version: 2.1\nName: gantry-sim\nVersion: 0.0.1\n")
    env = dict(os.environ, PYTHONPATH=str(tmp_path / "old"))
    start_worker(scheduler, tmp_path, env=env)
    prog = tmp_path / "p.ngc"
    prog.write_text(TINY)
    t0 = time.monotonic()
    status = main(["sweep", str(prog), "--executor", "dask", "--scheduler", scheduler])
    err = capsys.readouterr().err
    assert status == 2, err
    assert time.monotonic() - t0 < 20
    assert (
        f"of the scheduler at {scheduler} have gantry-sim 0.0.1, this client "
        f"{version('gantry-sim')}; install gantry-sim {version('gantry-sim')} on every worker"
    ) in err
    assert TRACEBACK not in err


def test_a_scheduler_without_workers_is_a_clear_error(scheduler, tmp_path, capsys, monkeypatch):
    # the wait shortened from its 10 s: what is tested is the message when it runs out
    monkeypatch.setattr(executors, "WORKER_TIMEOUT_S", 2)
    prog = tmp_path / "p.ngc"
    prog.write_text(TINY)
    t0 = time.monotonic()
    assert main(["sweep", str(prog), "--executor", "dask", "--scheduler", scheduler]) == 2
    assert time.monotonic() - t0 < 12
    err = capsys.readouterr().err
    assert (
        f"--scheduler: error: no Dask worker joined the scheduler at {scheduler} within 2 s" in err
    )
