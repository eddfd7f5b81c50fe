"""Chains planned elsewhere (a window's rounds planned ahead, planner/window_ahead.py) are used only
where they are the chain a round needs: the same key, limits and round setup."""

from __future__ import annotations

import math
import pickle

import numpy as np

from gantry_sim.controller.config import load_machine_config
from gantry_sim.controller.gcode.interpreter import interpret_events
from gantry_sim.controller.planner import rounds
from gantry_sim.controller.planner.chain_batch import ChainBatch
from gantry_sim.controller.planner.chains import Chain
from gantry_sim.controller.planner.path_stream import path_plan
from gantry_sim.controller.planner.prepare import prepare
from gantry_sim.controller.planner.ruckig_solver import RuckigSolver
from gantry_sim.controller.planner.transition import TransitionMachine
from gantry_sim.models import DEFAULT_MACHINE


def _settle(seed=None, plan_round=rounds.plan_chains_forked):
    """A blended polyline's chains, settled (with backed-off junctions: several rounds)."""
    out = ["G21 G90 G17 G64 P0.01", "G0 X0 Y0 Z-1", "F6000"]
    x = y = 0.0
    for k in range(60):
        heading = math.radians(25.0 * ((k % 4) - 1.5)) + 0.02 * k
        x, y = x + 0.2 * math.cos(heading), y + 0.2 * math.sin(heading)
        out.append(f"G1 X{x:.4f} Y{y:.4f}")
    machine = load_machine_config(DEFAULT_MACHINE)
    seg = machine.segmentation
    jerk = float(min(machine.limits.max_jerk_mm_per_s3))
    sizing = TransitionMachine(machine.limits, seg, 1.0)
    path = path_plan(
        tuple(interpret_events("\n".join(out) + "\nM2\n")),
        machine.path,
        seg.chord_tolerance_mm,
        frozenset(),
        jerk,
        sizing,
        {},
        None,
    )
    pre = prepare(path, machine, 100.0, {})
    return rounds.settle_chains(
        pre.active,
        pre.caps.copy(),
        pre.states,
        machine,
        RuckigSolver(machine.limits),
        "jerk3",
        pre.smoothing,
        seed=seed,
        plan_round=plan_round,
    )


def _seeds_of_every_round() -> tuple[dict, int]:
    """The chains each round planned, by seed key (as settle_onward sends them), and the
    rounds."""
    sent: dict = {}
    count = 0

    def plan_round(setup, todo, speeds, before):
        nonlocal count
        count += 1
        return rounds.plan_chains_sending(setup, todo, speeds, sent.update)

    _settle(plan_round=plan_round)
    return sent, count


def _same(a: rounds.Settled, b: rounds.Settled) -> None:
    assert a.spans == b.spans
    np.testing.assert_array_equal(a.speeds, b.speeds)
    for ca, cb in zip(a.chains, b.chains, strict=True):
        assert ca.duration_s == cb.duration_s and ca.starts_s == cb.starts_s
        assert pickle.dumps(ca.chunk) == pickle.dumps(cb.chunk)  # every phase, bit for bit


def test_the_chains_of_every_round_seeded_are_used_and_give_the_same_chains() -> None:
    plain = _settle()
    seeds, count = _seeds_of_every_round()
    assert count >= 2  # (rounds after the first: junctions backed off)
    assert any(not sat for _, _, sat in seeds)  # chains of the rounds after the first

    def nothing_left(setup, todo, speeds, before):
        assert todo == []  # every chain of every round is a seed
        return {}

    seeded = _settle(seed=seeds, plan_round=nothing_left)
    _same(plain, seeded)
    assert {id(c) for c in seeded.chains} <= {id(c) for c in seeds.values()}


def test_a_chain_planned_with_other_limits_or_round_setup_is_not_taken() -> None:
    plain = _settle()
    seeds, _ = _seeds_of_every_round()
    wrong = {}
    for (key, lim, sat), chain in seeds.items():  # each chain under a key it is not
        wrong[(key, rounds.replace(lim, acc_mm_per_s2=0.5 * lim.acc_mm_per_s2), sat)] = chain
        wrong[(key, lim, not sat)] = chain
    taken = {(k, lim, s) for k, lim, s in wrong if (k, lim, s) in seeds}
    wrong = {k: c for k, c in wrong.items() if k not in taken}
    _same(plain, _settle(seed=wrong))
    assert not {id(c) for c in _settle(seed=wrong).chains} & {id(c) for c in wrong.values()}


def test_a_batch_of_chains_unpickles_to_the_same_chains() -> None:
    """Every round's chains of a blended polyline (lines, blend arcs of closed-form and Ruckig
    pieces, chains with bad junctions and with none) through pickle, as a forked child sends
    them: the same keys in order and the same numbers."""
    sent, _ = _seeds_of_every_round()
    batch = ChainBatch(sent)
    back = pickle.loads(pickle.dumps(batch, protocol=pickle.HIGHEST_PROTOCOL))
    assert isinstance(back, ChainBatch) and list(back) == list(sent)
    assert any(c.bad for c in sent.values()) and any(c.ruckig_pieces for c in sent.values())
    for key, chain in sent.items():
        got = back[key]
        assert got.duration_s == chain.duration_s and got.starts_s == chain.starts_s
        assert got.bad == chain.bad and got.ruckig_pieces == chain.ruckig_pieces
        assert got.inner_speeds.dtype == chain.inner_speeds.dtype
        np.testing.assert_array_equal(got.inner_speeds, chain.inner_speeds)
        assert _arrays(got.chunk) == _arrays(chain.chunk)  # every phase, bit for bit


def _arrays(chunk: tuple) -> list[tuple[str, tuple[int, ...], str, bytes]]:
    """Each array of a chain's segments: its segment's kind, shape, type and bytes."""
    out = []
    for seg in chunk:
        kind = type(seg).__name__
        for a in (seg.rows,) if kind == "Jerk3Run" else seg if kind == "tuple" else (seg,):
            out.append((kind, a.shape, a.dtype.str, a.tobytes()))
    return out


def test_a_batch_keeps_segments_of_per_axis_phases_and_empty_chains() -> None:
    """A Ruckig piece whose axes switch jerk a different number of times is a segment of three
    (5, n_i) arrays (planner/cubic.py); a batch may be empty."""
    rng = np.random.default_rng(7)
    axes = tuple(rng.normal(size=(5, n)) for n in (3, 7, 5))
    whole = rng.normal(size=(3, 5, 4))
    chains = {
        (0, 1, 2.0, 3.0): Chain((axes, whole), 0.25, (0.0,), frozenset({1}), 1, np.array([])),
        (1, 3, 3.0, 0.0): Chain((whole, axes), 0.5, (0.0, 0.125), frozenset(), 0, np.array([4.5])),
    }
    back = pickle.loads(pickle.dumps(ChainBatch(chains)))
    for key, chain in chains.items():
        assert _arrays(back[key].chunk) == _arrays(chain.chunk)
        assert back[key].starts_s == chain.starts_s and back[key].bad == chain.bad
        np.testing.assert_array_equal(back[key].inner_speeds, chain.inner_speeds)
    empty = pickle.loads(pickle.dumps(ChainBatch()))
    assert isinstance(empty, ChainBatch) and not empty
