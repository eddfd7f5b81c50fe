"""Canned cycles in the XZ and YZ planes: the ``gen_cycpl_*`` family against rs274.

A review suspected G74/G84 (and maybe other cycles) of swapping axes in G18/G19. The family
``gen_cycpl_*`` (``scripts/rs274_cycle_plane_programs.py``) runs every supported cycle in
every plane, retract mode, distance mode and start level; its expectations are LinuxCNC 2.9's
``rs274 -g`` output (regenerate: ``python scripts/make_rs274_corpus.py`` then
``python scripts/regen_rs274_expected.py NAME ...``). ``tests/test_rs274_corpus.py`` compares
every program move by move; these tests keep the family complete and check the CLI end to end.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import pytest

from gantry_sim.sim.cli import main

DATA = Path(__file__).parent / "data" / "rs274"
sys.path.insert(0, str(Path(__file__).parent))
from test_rs274_corpus import _check_motion  # noqa: E402

CYCLES = ("g73", "g74", "g81", "g82", "g83", "g84", "g85", "g86", "g87", "g88", "g89")


def _expected(name: str) -> dict:
    return json.loads((DATA / "expected" / f"{name}.json").read_text())


@pytest.mark.parametrize("cycle", CYCLES)
def test_every_cycle_runs_in_every_plane_and_mode(cycle: str) -> None:
    """rs274 accepted each cycle in G17/G18/G19 x G98/G99 x G90/G91 (else the family proves
    nothing about that plane), and moved along the plane's drilling axis."""
    drill_axis = {"g17": 2, "g18": 1, "g19": 0}
    for plane, axis in drill_axis.items():
        for mode in ("g98", "g99"):
            for dist in ("g90", "g91"):
                name = f"gen_cycpl_{cycle}_{plane}_{mode}_{dist}_hi"
                want = _expected(name)
                assert "LinuxCNC 2.9" in want["origin"], name
                assert want["error"] is None, (name, want["error"])
                feeds = [m for m in want["motions"] if m["kind"] == "linear"]
                assert feeds, name
                # rs274 2.9 feeds G74/G84 to swapped coordinates in G18/G19 (canned_cycles._tap)
                if cycle not in ("g74", "g84") or plane == "g17":
                    for m in feeds:
                        moved = [
                            abs(e - s) > 1e-9 for s, e in zip(m["start"], m["end"], strict=True)
                        ]
                        assert moved == [k == axis for k in range(3)], (name, m)


@pytest.mark.parametrize("name", ["gen_cycpl_g84_g19_g98_g91_hi", "gen_cycpl_g74_g18_g99_g90_hi"])
def test_gantry_parse_taps_as_rs274_in_yz_and_xz(name: str, capsys) -> None:
    """`gantry parse` prints rs274's tapping moves, one JSON line per motion (mm, mm/min)."""
    assert main(["parse", str(DATA / "programs" / f"{name}.ngc")]) == 0
    got = [json.loads(x) for x in capsys.readouterr().out.splitlines()]
    want = _expected(name)
    assert len(got) == len(want["motions"])
    for i, (g, w) in enumerate(zip(got, want["motions"], strict=True)):
        assert not _check_motion(i, g, w, want["print_unit_mm"])


@pytest.mark.parametrize(
    "name",
    sorted(p.stem for p in (DATA / "programs").glob("gen_cycpl_err_*.ngc")),
)
def test_gantry_parse_refuses_what_rs274_refuses(name: str, capsys) -> None:
    """Exit 2 and FILE:LINE on rs274's failing line."""
    want = _expected(name)
    assert want["error"] is not None
    assert main(["parse", str(DATA / "programs" / f"{name}.ngc")]) == 2
    assert f"{name}.ngc:{want['error']['line']}:" in capsys.readouterr().err
