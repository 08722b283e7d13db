"""The machine-readable contract (shipradar.sim.stream.contract): the committed files are the
generator's output, the JSON Schemas hold every message of real recordings (checked with
``jsonschema``, a validator we did not write), and the AsyncAPI document passes the AsyncAPI
parser (``@asyncapi/parser`` from npm, installed when missing)."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

import msgpack
import pytest
import yaml

from shipradar.sim.engine.simulation import Simulation
from shipradar.sim.stream import contract, protocol, schema
from shipradar.sim.stream.bus import Bus
from shipradar.sim.stream.recording import Recorder, read_recording
from shipradar.sim.world.scenario import load_scenario
from tests.helpers import ROOT, free_port

jsonschema = pytest.importorskip("jsonschema")

COMMITTED = ROOT / "sim/stream/contract"
REGENERATE = ".venv/bin/python -m shipradar.sim.stream.contract sim/stream/contract"


def test_committed_contract_is_current():
    """The shipped files are what the generator writes from the schema today."""
    want = contract.contract_files()
    have = {p.name: p.read_text(encoding="utf-8") for p in COMMITTED.iterdir() if p.is_file()}
    stale = sorted(n for n in want if have.get(n) != want[n])
    extra = sorted(set(have) - set(want))
    assert not stale and not extra, (
        f"sim/stream/contract is not current (stale {stale}, not generated {extra}): "
        f"run `{REGENERATE}` (and delete files it does not write), then commit the files")


def test_contract_dir_is_the_package_data():
    assert contract.contract_dir().resolve() == COMMITTED.resolve()
    pyproject = (ROOT / "pyproject.toml").read_text(encoding="utf-8")
    assert '"shipradar.sim.stream" = ["contract/*.json", "contract/*.yaml"]' in pyproject


def _schemas() -> dict[str, dict]:
    return {p.name: json.loads((COMMITTED / contract.schema_file_name(p)).read_text("utf-8"))
            for p in schema.PAYLOADS}


def _keywords(node, out: set[str]) -> set[str]:
    """Every keyword of a schema (the keys of schema objects, not of ``properties``)."""
    if isinstance(node, dict):
        for k, v in node.items():
            out.add(k)
            if k == "properties":
                for sub in v.values():
                    _keywords(sub, out)
            elif isinstance(v, (dict, list)) and k not in ("enum", "const", "required",
                                                             "default", "examples"):
                _keywords(v, out)
    elif isinstance(node, list):
        for v in node:
            _keywords(v, out)
    return out


def test_one_dialect_and_declared_annotations():
    """Every file states draft-07 (AsyncAPI 3.0's JSON Schema dialect, the AsyncAPI document's
    ``schemaFormat`` too), so a default validator picks it without guessing; every keyword
    is the dialect's own or one of the declared annotations (a strict validator's check)."""
    doc = yaml.safe_load((COMMITTED / contract.ASYNCAPI_FILE).read_text(encoding="utf-8"))
    known = set(jsonschema.Draft7Validator.META_SCHEMA["properties"])
    for name, s in _schemas().items():
        assert s["$schema"] == contract.DIALECT
        assert jsonschema.validators.validator_for(s) is jsonschema.Draft7Validator
        embedded = doc["components"]["schemas"][name.replace("[", "_").replace("]", "")]
        assert embedded["schemaFormat"] == "application/schema+json;version=draft-07"
        assert embedded["schema"]["$schema"] == contract.DIALECT
        unknown = _keywords(s, set()) - known - set(contract.ANNOTATIONS)
        assert not unknown, (name, unknown)
    assert "x-topic" in contract.ANNOTATIONS  # the keyword a strict validator first refused


def test_version_2_keys_are_required_in_version_2(validators):
    """``if v = 2 then required [...]``: a version-2 message lacking a key version 2 added
    is refused, the same message as version 1 passes."""
    validator, _ = validators[(b"eos", None)]
    good = {"v": 2, "t": 4.0, "sensor": "r", "scan": 0, "time_s": 4.0,
            "position": {"lat_deg": 45.0, "lon_deg": -63.0, "alt_m": 20.0, "east_m": 0.0,
                         "north_m": 0.0, "up_m": 20.0},
            "velocity_enu_mps": [0.0, 5.0, 0.0], "heading_deg": 0.0, "complete": True}
    assert validator.is_valid(good)
    lacking = {k: v for k, v in good.items() if k != "complete"}
    assert not validator.is_valid(lacking)
    assert validator.is_valid({**lacking, "v": 1})
    assert not validator.is_valid({**good, "position": {"lat_deg": 45.0}})
    for p in schema.PAYLOADS:
        want = [f.key for f in p.fields if f.required_since == 2]
        got = [k for c in _schemas()[p.name].get("allOf", []) for k in c["then"]["required"]]
        assert got == want, p.name


def test_json_schemas_are_valid_and_follow_the_schema_module():
    for name, s in _schemas().items():
        jsonschema.Draft7Validator.check_schema(s)
        jsonschema.Draft202012Validator.check_schema(s)
        p = next(p for p in schema.PAYLOADS if p.name == name)
        assert list(s["properties"]) == ["v", "t", *p.keys]
        for f in p.fields:
            prop = s["properties"][f.key]
            assert prop["description"] == f.meaning
            assert prop.get("x-unit", "") == f.unit
            if f.dtype is not None:
                assert prop["x-dtype"] == f.dtype.name and prop["x-length"] == f.length
            assert (f.key in s["required"]) == f.required


def test_unknown_type_is_refused():
    with pytest.raises(ValueError, match="does not know"):
        contract.field_schema(schema.Field("x", "complex[n]", "", "?"))
    assert contract.field_schema(schema.Field("x", "float32[r, s]", "m", "?"))["x-length"] == [
        "r", "s"]


def _ext_hook(code: int, data: bytes):
    return protocol.decode_array(data) if code == protocol.EXT_NDARRAY else msgpack.ExtType(
        code, data)


def _record(tmp_path: Path, name: str, duration_s: float) -> Path:
    path = tmp_path / f"{name}.srrec"
    name, _, errors = name.partition("+")
    s = load_scenario(ROOT / f"scenarios/{name}.yaml")
    if errors:  # issue 33: truth[sensors], navigated meta and eos
        d = s.model_dump(mode="json")
        d["platforms"][0]["navigation"] = {"east_error_m": 20.0, "heading_bias_deg": {
            "mean": 0.1, "sigma": 0.05, "correlation_time_s": 60.0}}
        d["platforms"][0]["radars"][0]["errors"] = {
            "range_bias_m": 150.0, "time_offset_s": 0.05, "time_jitter_s": 0.001}
        s = type(s).model_validate(d)
    with Bus(None, Recorder(path)) as bus:
        Simulation(s, bus=bus, duration_s=duration_s, seed=7).run()
    return path


@pytest.fixture(scope="module")
def validators():
    out = {}
    for name, s in _schemas().items():
        p = next(p for p in schema.PAYLOADS if p.name == name)
        out[(p.topic, p.kind)] = (jsonschema.validators.validator_for(s)(s), s)
    return out


@pytest.mark.parametrize(("name", "duration_s"), [
    ("raid", 12.0), ("jammed_squall", 4.0), ("manoeuvres", 4.0), ("raid+errors", 6.0)])
def test_every_recorded_message_is_valid(tmp_path, validators, name, duration_s):
    """Each message of a real recording, decoded (section 5) and in its JSON form (as
    ``shipradar tail`` prints it), validates against its payload's JSON Schema; its keys are
    all declared there, and the columns of one length (``x-length``) have one length. The
    first message of each payload, without any one key version 2 added, is refused."""
    counts: Counter[str] = Counter()
    with read_recording(_record(tmp_path, name, duration_s), strict=True) as reader:
        for _, (topic, body) in reader:
            msg = msgpack.unpackb(body, ext_hook=_ext_hook, raw=False)
            kind = msg.get("kind") if topic == b"truth" else None
            validator, s = validators[(topic, kind)]
            doc = protocol.to_jsonable(msg)
            errors = sorted(validator.iter_errors(doc), key=lambda e: list(e.path))
            assert not errors, f"{name} {topic!r} t={msg['t']}: {errors[0].message} at " \
                               f"{list(errors[0].path)}"
            assert set(doc) <= set(s["properties"]), set(doc) - set(s["properties"])
            lengths: dict[str, set[int]] = {}
            for key, prop in s["properties"].items():
                if key in doc and isinstance(prop.get("x-length"), str):
                    lengths.setdefault(prop["x-length"], set()).add(len(doc[key]))
            assert all(len(v) == 1 for v in lengths.values()), lengths
            if "n" in lengths and "n+1" in lengths:
                assert lengths["n+1"] == {next(iter(lengths["n"])) + 1}
            label = f"{topic.decode()}" + (f"[{kind}]" if kind else "")
            if not counts[label]:  # a real version-2 message lacking a version-2 key fails
                p = next(p for p in schema.PAYLOADS if p.name == label)
                for key in (f.key for f in p.fields if f.required_since == 2):
                    assert doc["v"] == 2 and key in doc, (label, key)
                    assert not validator.is_valid({k: v for k, v in doc.items() if k != key})
            counts[label] += 1
    # every payload shipradar sends (all but the trackers' tracks and registration, the
    # entities only a live run records, tests/test_entities.py, and the sensors' errors only
    # a scene with errors has) occurs
    assert set(counts) == {p.name for p in schema.PAYLOADS
                           if p.topic not in (schema.TOPIC_TRACKS, schema.TOPIC_REGISTRATION,
                                              schema.TOPIC_ENTITIES)
                           and (p is not schema.TRUTH_SENSORS or "+errors" in name)}, counts
    print(f"{name}: {sum(counts.values())} messages valid {dict(counts)}")


def test_a_wrong_message_is_refused(validators):
    validator, _ = validators[(b"plots", None)]
    good = {"v": protocol.SCHEMA_VERSION, "t": 1.0, "sensor": "r", "scan": 0, "plot_id": [1],
            "time_s": [0.5], "range_m": [1e3], "azimuth_rad": [0.1], "snr_db": [None],
            "sigma_range_m": [3.0], "sigma_azimuth_rad": [1e-3], "interference": [0]}
    assert validator.is_valid(good)
    for bad in ({**good, "v": 99}, {**good, "interference": [256]},
                {k: v for k, v in good.items() if k != "range_m"},
                {**good, "plot_id": [1.5]}, {**good, "scan": "0"}):
        assert not validator.is_valid(bad)


def test_registration_message_is_checked(validators):
    """A tracker's ``registration`` message (section 4.8): the keys of
    ``truth[sensors]``'s errors, each optional; ``sensor`` and ``time_s`` required."""
    validator, s = validators[(schema.TOPIC_REGISTRATION, None)]
    good = {"v": protocol.SCHEMA_VERSION, "t": 8.0, "sensor": "a", "time_s": 8.0,
            "source": "template", "range_bias_m": 150.0, "azimuth_bias_rad": 0.005,
            "sigma_range_bias_m": 10.0}
    assert validator.is_valid(good)
    assert validator.is_valid({k: v for k, v in good.items() if k != "source"})
    for bad in ({k: v for k, v in good.items() if k != "sensor"},
                {k: v for k, v in good.items() if k != "time_s"},
                {**good, "range_bias_m": "150"}, {**good, "sensor": 3}):
        assert not validator.is_valid(bad)
    assert s["x-topic"] == "registration"


# --------------------------------------------------------------------- the AsyncAPI document
_VALIDATE_JS = """
import { Parser } from '@asyncapi/parser';
import fs from 'node:fs';
const path = process.argv[2];
const { document, diagnostics } = await new Parser().parse(fs.readFileSync(path, 'utf8'),
                                                           { source: path });
const sev = ['error', 'warning', 'info', 'hint'];
console.log(JSON.stringify({
  valid: document !== undefined,
  diagnostics: diagnostics.map(d => ({ severity: sev[d.severity], code: d.code,
                                       message: d.message, path: d.path.join('/') })),
  channels: document ? document.channels().length : 0,
  messages: document ? document.allMessages().length : 0,
  operations: document ? document.operations().length : 0 }));
"""


def _asyncapi_parser() -> Path | None:
    """A directory holding ``validate.mjs`` and ``node_modules/@asyncapi/parser``; npm
    installs the parser there when it is missing (a directory of the system's temporary
    directory, kept across runs; ``SHIPRADAR_ASYNCAPI_DIR`` overrides it)."""
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        return None
    where = Path(os.environ.get("SHIPRADAR_ASYNCAPI_DIR",
                                Path(tempfile.gettempdir()) / "shipradar-asyncapi-parser"))
    where.mkdir(parents=True, exist_ok=True)
    if not (where / "node_modules/@asyncapi/parser/package.json").exists():
        subprocess.run([npm, "install", "--no-audit", "--no-fund", "--prefix", str(where),
                        "@asyncapi/parser@3"], capture_output=True, text=True, timeout=600)
    if not (where / "node_modules/@asyncapi/parser/package.json").exists():
        return None
    (where / "validate.mjs").write_text(_VALIDATE_JS, encoding="utf-8")
    return where


def test_asyncapi_document_passes_the_asyncapi_parser():
    where = _asyncapi_parser()
    if where is None:
        message = "node/npm or @asyncapi/parser unavailable (npm install @asyncapi/parser)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    proc = subprocess.run(["node", str(where / "validate.mjs"),
                           str(COMMITTED / contract.ASYNCAPI_FILE)],
                          capture_output=True, text=True, timeout=120, cwd=where)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    problems = [d for d in report["diagnostics"] if d["severity"] in ("error", "warning")]
    assert report["valid"] and not problems, problems
    assert report["channels"] == len({p.topic for p in schema.PAYLOADS})
    assert report["messages"] == len(schema.PAYLOADS)
    assert report["operations"] == report["channels"]


_AJV_JS = """
const fs = require('fs'); const path = require('path');
const Ajv = require('ajv').default;
const [dir, vocabulary] = [process.argv[2], JSON.parse(process.argv[3])];
const out = {};
for (const f of fs.readdirSync(dir).filter(f => f.endsWith('.schema.json'))) {
  const schema = JSON.parse(fs.readFileSync(path.join(dir, f)));
  for (const [mode, words] of [['declared', vocabulary], ['undeclared', []]]) {
    const ajv = new Ajv({ strict: true }); ajv.addVocabulary(words);
    try { ajv.compile(schema); out[f + ' ' + mode] = 'ok'; }
    catch (e) { out[f + ' ' + mode] = e.message; }
  }
}
console.log(JSON.stringify(out));
"""


def test_ajv_strict_loads_the_schemas_with_the_declared_annotations():
    """ajv 8 (the AsyncAPI parser's own, from npm) in strict mode with its default dialect
    (draft-07) compiles every schema once told :data:`contract.ANNOTATIONS` (section 10),
    and refuses them without (the setting section 10 states is needed)."""
    where = _asyncapi_parser()
    if where is None or not (where / "node_modules/ajv/package.json").exists():
        message = "node/npm or ajv unavailable (npm install @asyncapi/parser)"
        if os.environ.get("CI"):
            pytest.fail(message)
        pytest.skip(message)
    (where / "ajv_strict.cjs").write_text(_AJV_JS, encoding="utf-8")
    proc = subprocess.run(["node", str(where / "ajv_strict.cjs"), str(COMMITTED),
                           json.dumps(list(contract.ANNOTATIONS))],
                          capture_output=True, text=True, timeout=120, cwd=where)
    assert proc.returncode == 0, proc.stderr
    report = json.loads(proc.stdout)
    assert len(report) == 2 * len(schema.PAYLOADS)
    for name, verdict in report.items():
        if name.endswith("declared") and not name.endswith("undeclared"):
            assert verdict == "ok", (name, verdict)
        else:
            assert "unknown keyword" in verdict, (name, verdict)


def test_asyncapi_document_uses_the_json_schemas():
    doc = yaml.safe_load((COMMITTED / contract.ASYNCAPI_FILE).read_text(encoding="utf-8"))
    assert doc["asyncapi"] == "3.0.0"
    for name, s in _schemas().items():
        ref = name.replace("[", "_").replace("]", "")
        embedded = doc["components"]["schemas"][ref]["schema"]
        assert embedded["properties"] == s["properties"]
        assert embedded["required"] == s["required"]
        assert doc["components"]["messages"][ref]["x-schema-file"] == \
            contract.schema_file_name(next(p for p in schema.PAYLOADS if p.name == name))


def test_truth_kinds_have_a_discriminator():
    """The two payloads of `truth` are one union told apart by `kind` (AsyncAPI Schema
    Object's `discriminator`), each member's `kind` a `const` naming it, and the channel maps
    each `kind` to its message."""
    doc = yaml.safe_load((COMMITTED / contract.ASYNCAPI_FILE).read_text(encoding="utf-8"))
    union = doc["components"]["schemas"]["truth"]
    assert union["discriminator"] == "kind"
    kinds = {}
    for member in union["oneOf"]:
        path = member["$ref"].removeprefix("#/").split("/")
        target = doc
        for part in path:
            target = target[part]
        kinds[target["properties"]["kind"]["const"]] = path[2]
    assert kinds == {p.kind: p.name.replace("[", "_").replace("]", "")
                     for p in schema.PAYLOADS if p.topic == b"truth"}
    mapping = doc["channels"]["truth"]["x-discriminator"]["mapping"]
    assert {k: v.rsplit("/", 1)[1] for k, v in mapping.items()} == kinds


# --------------------------------------------------------------------- the run summary
def _summary_rows() -> list[tuple[str, str]]:
    """(key, meaning) of each row of docs/protocol.md section 11's table."""
    text = (ROOT / "docs/protocol.md").read_text(encoding="utf-8")
    part = text[text.index("\n## 11. Run summary"):]
    rows = []
    for line in part.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("| `") and len(cells) == 4:
            rows.append((cells[0].strip("`"), cells[3]))
    return rows


def test_run_summary_is_specified(tmp_path):
    """Every key of ``shipradar run``'s summary line (recording and publishing) is in section 11, in
    order; every key not marked optional is in the summary; the bus's keys are named."""
    proc = subprocess.run(
        [sys.executable, "-m", "shipradar.sim.cli", "run", "--example", "single_missile",
         "--duration", "2", "--quiet", "--record", str(tmp_path / "run.srrec"),
         "--publish", f"tcp://127.0.0.1:{free_port()}"],
        capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    summary = json.loads(proc.stdout.strip().splitlines()[-1])
    rows = _summary_rows()
    documented = [k for k, _ in rows]
    assert [k for k in documented if k in summary] == list(summary), (documented, summary)
    assert [k for k, m in rows if "*optional*" not in m and k not in summary] == []
    bus_row = dict(rows)["bus"]
    bus = summary["bus"]
    for key in [*bus, *bus["recorder"], *bus["publisher"]]:
        assert f"`{key}`" in bus_row, key
