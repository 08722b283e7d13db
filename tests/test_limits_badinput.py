"""Bad-input catalogue, part 2: recordings, keys, budgets, endpoints, through the CLI.

With tests/test_scenario.py (scenario fields and files) and tests/test_curve.py (key files)
this brings the catalogue past 50 distinct bad inputs, each with its exact one-line message
and exit 2. Every case here runs in process and fails before anything is built or bound.
"""

from __future__ import annotations

import struct
import zlib

import pytest
import yaml

from shipradar.sim.cli import main
from shipradar.sim.stream.recording import MAGIC, Recorder

from .helpers import ROOT

SCENE = str(ROOT / "scenarios/single_missile.yaml")


def _files(d):
    """The files the cases refer to, created in ``d``; returns their paths by name."""
    p = {name: d / name for name in ("good.srrec", "junk.srrec", "future.srrec",
                                     "v99.srrec", "damaged.srrec", "exists.srrec",
                                     "keys", "nokey.txt", "adir", "big.yaml")}
    with Recorder(p["good.srrec"]) as rec:
        for i in range(5):
            rec.write(float(i), [b"eos", b"\x80" * (10 + i)])
    data = p["good.srrec"].read_bytes()
    p["junk.srrec"].write_bytes(b"this is not a recording at all")
    head = MAGIC + struct.pack("<HHH", 7, 1, 0)
    p["future.srrec"].write_bytes(head + struct.pack("<H", zlib.crc32(head) & 0xFFFF))
    p["v99.srrec"].write_bytes(MAGIC + struct.pack("<HHI", 99, 1, 0))
    bad = bytearray(data)
    bad[16 + 32 + 4] ^= 1  # first record's payload
    p["damaged.srrec"].write_bytes(bytes(bad))
    p["exists.srrec"].write_bytes(b"precious")
    from shipradar.sim.stream.security import generate_keys

    generate_keys(p["keys"], clients=["alice"])
    p["nokey.txt"].write_text("metadata\n    nothing = \"here\"\n")
    p["adir"].mkdir()
    d_big = yaml.safe_load((ROOT / "scenarios/raid.yaml").read_text())
    d_big["platforms"][0]["radars"][1]["frequency_hz"] = 9.5e10
    d_big["platforms"][0]["radars"][1]["instrumented_range_m"] = 400000.0
    p["big.yaml"].write_text(yaml.safe_dump(d_big, sort_keys=False))
    return p


#: (argv with {names} of _files, the exact line on stderr); {names} are substituted.
CASES = [
    (["recording", "verify", "{nope}"],
     "recording verify: {nope} does not exist or is not a file"),
    (["recording", "verify", "{adir}"],
     "recording verify: {adir} does not exist or is not a file"),
    (["recording", "verify", "{junk.srrec}"],
     "{junk.srrec} is not a shipradar recording (bad magic)"),
    (["recording", "verify", "{future.srrec}"],
     "{future.srrec} has recording format version 7; this reader supports [1, 2]"),
    (["recording", "verify", "{v99.srrec}"],
     "{v99.srrec} has recording format version 99; this reader supports [1, 2]"),
    (["run", SCENE, "--processes", "2", "--realtime", "5"],
     "--processes 2 is for fast mode; drop --realtime or use --processes 1"),
    (["replay", "{nope}"], "replay: recording {nope} does not exist"),
    (["replay", "{junk.srrec}", "--fast"],
     "{junk.srrec} is not a shipradar recording (bad magic)"),
    (["replay", "{future.srrec}", "--fast"],
     "{future.srrec} has recording format version 7; this reader supports [1, 2]"),
    (["replay", "{good.srrec}", "--publish", "tcp://0.0.0.0:5999"],
     "refusing to bind tcp://0.0.0.0:5999: it is reachable from other machines; bind a "
     "loopback address such as tcp://127.0.0.1:5555, secure the stream with CURVE "
     "(--curve-secret-key and --curve-authorized; shipradar keys generate DIR), or accept "
     "anyone on the network with --allow-insecure-remote"),
    (["replay", "{good.srrec}", "--publish", "tcp://"],
     "malformed endpoint 'tcp://': expected e.g. tcp://127.0.0.1:5555"),
    (["replay", "{good.srrec}", "--publish", "udp://127.0.0.1:5999"],
     "refusing to bind udp://127.0.0.1:5999: transport 'udp' is not local; bind a loopback "
     "address such as tcp://127.0.0.1:5555, secure the stream with CURVE (--curve-secret-key "
     "and --curve-authorized; shipradar keys generate DIR), or accept anyone on the network "
     "with --allow-insecure-remote"),
    (["replay", "{damaged.srrec}", "--fast", "--strict", "--publish", "tcp://127.0.0.1:*"],
     "{damaged.srrec}: record fails its CRC check at byte 16 (corrupt file)"),
    (["replay", "{good.srrec}", "--curve-authorized", "{keys}/authorized"],
     "--curve-authorized needs --curve-secret-key FILE too"),
    (["replay", "{good.srrec}", "--curve-secret-key", "{adir}", "--curve-authorized",
      "{keys}/authorized"], "--curve-secret-key: {adir} is not a file"),
    (["replay", "{good.srrec}", "--curve-secret-key", "{keys}/server.key_secret",
      "--curve-authorized", "{nokey.txt}"],
     "--curve-authorized: {nokey.txt} is not a directory of public keys (*.key)"),
    (["replay", "{good.srrec}", "--curve-secret-key", "{nokey.txt}", "--curve-authorized",
      "{keys}/authorized"],
     "--curve-secret-key: {nokey.txt} is not a CURVE key file (No public key found in "
     "{nokey.txt})"),
    (["tail", "tcp://127.0.0.1:1", "--curve-secret-key", "{keys}/alice.key_secret"],
     "--curve-secret-key needs --curve-server-key FILE too"),
    (["tail", "tcp://127.0.0.1:1", "--curve-secret-key", "{keys}/alice.key_secret",
      "--curve-server-key", "{nope}"],
     "--curve-server-key: cannot read {nope} (No such file or directory)"),
    (["recording", "repair", "{nope}", "{out}"],
     "recording repair: {nope} does not exist or is not a file"),
    (["recording", "repair", "{good.srrec}", "{exists.srrec}"],
     "repair: OUT {exists.srrec} exists; pass --overwrite to replace it"),
    (["recording", "repair", "{good.srrec}", "{good.srrec}", "--overwrite"],
     "repair: OUT {good.srrec} is the input file itself; give a new file"),
    (["recording", "repair", "{junk.srrec}", "{out}"],
     "{junk.srrec} is not a shipradar recording (bad magic)"),
    (["run", SCENE, "--record", "{exists.srrec}"],
     "--record: {exists.srrec} exists; pass --overwrite to replace it"),
    (["keys", "generate", "{keys}"],
     "keys generate: {keys}/server.key exists; choose another DIR or --name"),
    (["keys", "generate", "{newkeys}", "--name", "authorized"],
     "key name 'authorized': must be a plain file name"),
    (["keys", "generate", "{newkeys}", "--name", "a", "--name", "a"],
     "key names must differ, got ['server', 'a', 'a']"),
    (["keys", "generate", "{newkeys}", "--name", "../up"],
     "key name '../up': must be a plain file name"),
]


@pytest.mark.parametrize("argv,message", CASES, ids=[m[:50] for _, m in CASES])
def test_bad_input_exact_line_and_exit_2(tmp_path, capsys, argv, message):
    files = {k: str(v) for k, v in _files(tmp_path).items()}
    files.update(nope=str(tmp_path / "nope.srrec"), out=str(tmp_path / "out.srrec"),
                 newkeys=str(tmp_path / "newkeys"))

    def sub(text: str) -> str:
        for k, v in files.items():
            text = text.replace("{" + k + "}", v)
        return text

    before = {k: (tmp_path / k).read_bytes() for k in ("good.srrec", "exists.srrec")}
    assert main([sub(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err == sub(message) + "\n"
    assert {k: (tmp_path / k).read_bytes() for k in before} == before  # nothing touched
    assert not (tmp_path / "out.srrec").exists() and not (tmp_path / "newkeys").exists()


def test_budget_errors_exact(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("SHIPRADAR_MEMORY_BUDGET_MIB", "lots")
    assert main(["tables", "build", SCENE]) == 2
    assert capsys.readouterr().err == ("SHIPRADAR_MEMORY_BUDGET_MIB must be a number of MiB, "
                                       "got 'lots'\n")
    monkeypatch.setenv("SHIPRADAR_MEMORY_BUDGET_MIB", "-5")
    assert main(["tables", "build", SCENE]) == 2
    assert capsys.readouterr().err == "SHIPRADAR_MEMORY_BUDGET_MIB must be > 0, got -5\n"


@pytest.mark.parametrize("argv,line", [
    (["run", SCENE, "--memory-budget", "0"],
     "shipradar run: error: argument --memory-budget: --memory-budget must be > 0, got 0"),
    (["run", SCENE, "--processes", "0"],
     "shipradar run: error: argument --processes: --processes must be an integer in [1, 64], "
     "got '0'"),
    (["run", SCENE, "--compress", "gzip"],
     "shipradar run: error: argument --compress: invalid choice: 'gzip' (choose from 'none', "
     "'zstd')"),
    (["recording", "repair", "a", "b", "--compress", "lz4"],
     "shipradar recording repair: error: argument --compress: invalid choice: 'lz4' (choose "
     "from 'none', 'zstd')"),
])
def test_bad_options_exit_2_with_the_option_named(capsys, argv, line):
    with pytest.raises(SystemExit) as exc:
        main(argv)
    assert exc.value.code == 2
    assert capsys.readouterr().err.splitlines()[-1] == line
