"""benchmarks/peer_programs.py writes the committed peer programs, byte for byte: the LinuxCNC
cycle times in benchmarks/data/linuxcnc_peer.json were measured on those files."""

from __future__ import annotations

import hashlib
import json

from benchmarks.peer_programs import OUT, files, main

PEER = OUT.parent / "data" / "linuxcnc_peer.json"


def test_writer_output_matches_the_committed_files(tmp_path, monkeypatch):
    monkeypatch.setattr("sys.argv", ["peer_programs.py", str(tmp_path)])
    main()
    written = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    committed = {p.name: p.read_bytes() for p in OUT.glob("*.ngc")}
    assert written == committed
    assert written == {name: text.encode() for name, text in files().items()}


def test_linuxcnc_times_were_recorded_on_these_files():
    peer = json.loads(PEER.read_text())
    recorded = {
        rec["file"].rpartition("/")[2]: rec["sha256"]
        for by_mode in peer["programs"].values()
        for rec in by_mode.values()
    }
    assert recorded == {
        p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in OUT.glob("*.ngc")
    }
    assert all(
        rec["cycle_s"] > 0 for by_mode in peer["programs"].values() for rec in by_mode.values()
    )
