"""The long contract fuzz (issue 15): many more of tests/test_fuzz_contract.py's inputs.

    python scripts/fuzz_contract.py --examples 200 --seed 1 [--json fuzz.json]

Runs each input family through its commands in-process, never stops at a violation (memory capped, see
--memory-gb), and prints
per family and command the counts of outcomes: exit 0, 1, 2, and the violations (exit 3 or
another status, a traceback, an exit 2 without ``FILE[:LINE]: error:``, over the time bound),
with the first few violating inputs. ``--examples`` is per family (hostile options: per
command). Exit status 0 when no input broke the contract, 1 otherwise.
"""

from __future__ import annotations

import argparse
import collections
import json
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from fuzz_inputs import (  # noqa: E402 - after the path set-up
    OPTIONS,
    call,
    hostile_machine_files,
    hostile_options,
    hostile_programs,
    valid_programs,
)
from hypothesis import HealthCheck, given, seed, settings  # noqa: E402

LIMIT_S = 120.0
SMALL_BUDGET = ["--max-sim-s", "20"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=int, default=200, help="inputs per family (default 200)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--json", type=Path, default=None, help="also write the counts here")
    ap.add_argument("--only", default=None, help="run only the families containing this text")
    ap.add_argument(
        "--memory-gb",
        type=float,
        default=4.0,
        help="address-space limit of this process (default 4): an input that needs more is a "
        "MemoryError, counted as a violation (exit 3)",
    )
    args = ap.parse_args()
    import resource

    limit = int(args.memory_gb * 2**30)
    resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
    with tempfile.TemporaryDirectory(prefix="gantry-fuzz-") as tmp:  # removed however it ends
        return _fuzz(args, Path(tmp))


def _fuzz(args: argparse.Namespace, work: Path) -> int:
    """Every family's inputs, written into ``work``; the counts printed; the exit status."""
    counts: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
    examples: dict[str, list[str]] = collections.defaultdict(list)

    def record(family: str, argv: list[str], note: str = "", expect_ok: bool = False) -> None:
        out = call(argv)
        problem = out.violation(LIMIT_S)
        if problem is None and expect_ok and out.status != 0:
            problem = f"a valid program exited {out.status}"
        key = f"{family} [{argv[0]}]"
        counts[key][f"exit {out.status}" if problem is None else f"VIOLATION: {problem}"] += 1
        if problem is not None and len(examples[key]) < 5:
            last = out.stderr.strip().splitlines()[-1:] or [""]
            examples[key].append(f"{' '.join(argv)} {note}\n      -> {last[0][:300]}")

    def write(name: str, data: str | bytes) -> str:
        path = work / name
        path.write_bytes(data.encode() if isinstance(data, str) else data)
        return str(path)

    def family(name: str, strategy, body, n: int) -> None:
        if args.only and args.only not in name:
            return

        @seed(args.seed)
        @settings(
            max_examples=n,
            database=None,
            deadline=None,
            phases=[__import__("hypothesis").Phase.generate],
            suppress_health_check=list(HealthCheck),
        )
        @given(strategy)
        def run(value):
            body(value)

        t0 = time.monotonic()
        run()
        print(f"{name}: {time.monotonic() - t0:.0f} s", file=sys.stderr, flush=True)

    n = args.examples

    def valid(program: str) -> None:
        p = write("v.ngc", program)
        record("valid programs", ["plan", p], repr(program), expect_ok=True)

    def valid_run(program: str) -> None:
        p = write("v.ngc", program)
        record("valid programs", ["run", p, "--out", str(work / "o")], repr(program), True)

    def hostile(data: bytes) -> None:
        p = write("h.ngc", data)
        record("hostile programs", ["parse", p], repr(data[:200]))
        record("hostile programs", ["plan", p], repr(data[:200]))

    def machine(text: str) -> None:
        p, m = write("p.ngc", "G1 X0.5 F600\nM2\n"), write("m.toml", text)
        record("hostile machine files", ["plan", p, "--machine", m], repr(text[:200]))
        record(
            "hostile machine files",
            ["run", p, "--machine", m, "--out", str(work / "o"), *SMALL_BUDGET],
            repr(text[:200]),
        )

    family("valid programs (plan)", valid_programs(), valid, n)
    family("valid programs (run)", valid_programs(max_moves=2), valid_run, max(1, n // 10))
    family("hostile programs", hostile_programs(), hostile, n)
    family("hostile machine files", hostile_machine_files(), machine, n)
    prog = write("c.ngc", "G21 G90 G17\nG0 X3 Y0\nG3 I-3 J0 F2400\nM2\n")
    for command in OPTIONS:

        def options(opts: list[str], command: str = command) -> None:
            argv = [command] + ([prog] if command in ("parse", "plan", "run", "sweep") else [])
            argv += opts
            if command in ("run", "ballbar", "tune", "sweep"):
                argv += ["--out", str(work / "o")]
                if not any(o.startswith("--max-sim-s") for o in opts):
                    argv += SMALL_BUDGET
            if command == "sweep" and not any(o.startswith("--workers") for o in opts):
                argv += ["--workers", "1"]
            record("hostile options", argv)

        k = n if command in ("parse", "plan") else max(1, n // 4)
        family(f"hostile options ({command})", hostile_options(command), options, k)

    total = collections.Counter()
    for key in sorted(counts):
        print(f"{key}: " + ", ".join(f"{k} {v}" for k, v in sorted(counts[key].items())))
        for ex in examples[key]:
            print(f"    {ex}")
        total.update(counts[key])
    print("total: " + ", ".join(f"{k} {v}" for k, v in sorted(total.items())))
    print(f"inputs: {sum(total.values())} calls")
    if args.json:
        args.json.write_text(json.dumps({k: dict(v) for k, v in counts.items()}, indent=2))
    return 1 if any(k.startswith("VIOLATION") for k in total) else 0


if __name__ == "__main__":
    sys.exit(main())
