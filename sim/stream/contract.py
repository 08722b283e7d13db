"""The stream's machine-readable contract, generated from :mod:`shipradar.sim.stream.schema`.

Two kinds of file, written into ``sim/stream/contract/`` and shipped in the wheel
(``shipradar/sim/stream/contract/``, read with :func:`contract_dir`):

- ``<payload>.schema.json``, one JSON Schema (draft-07, :data:`DIALECT`) per payload of
  :data:`shipradar.sim.stream.schema.PAYLOADS` (``meta``, ``plots``, ``eos``,
  ``truth-plots``, ``truth-targets``, ``tracks``, ``entities``, ``registration``): the
  decoded body (envelope ``v``, ``t`` and the payload's keys) in its JSON form, that of
  ``shipradar tail`` and :func:`shipradar.sim.stream.protocol.to_jsonable`
  (docs/protocol.md section 5): a numpy column is a list of its elements, NaN and ±inf are
  ``null``.  Every key carries its unit
  (``x-unit``) and meaning (``description``); a column also its element type on the wire
  (``x-dtype``, ``x-typestr``: msgpack extension type 1, docs/protocol.md section 3) and its
  length (``x-length``: ``n`` one per plot, ``n+1``, ``m``, ``k`` one per target), which JSON
  Schema itself cannot tie between keys.  Unknown keys are allowed (a new key does not bump
  the schema version, section 2); required ones are listed.
- ``asyncapi.yaml``: an AsyncAPI 3.0 document of the ZeroMQ PUB/SUB topics (channels
  ``meta``, ``plots``, ``eos``, ``truth``, the tracker's ``tracks`` and ``registration``),
  whose message payloads are the same schemas.

``python -m shipradar.sim.stream.contract OUTDIR`` writes them (the committed copy is
checked current by ``tests/test_contract.py``).
"""

from __future__ import annotations

import json
import re
import sys
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from shipradar.sim.stream.protocol import (
    EXT_NDARRAY,
    MAX_BODY_BYTES,
    SCHEMA_VERSION,
    SUPPORTED_SCHEMA_VERSIONS,
)
from shipradar.sim.stream.schema import PAYLOADS, Field, Payload

__all__ = [
    "ANNOTATIONS",
    "ASYNCAPI_FILE",
    "DIALECT",
    "asyncapi_document",
    "contract_dir",
    "contract_files",
    "field_schema",
    "payload_schema",
    "schema_file_name",
    "write_contract",
]

#: File name of the AsyncAPI document in the contract directory.
ASYNCAPI_FILE = "asyncapi.yaml"
#: The JSON Schema dialect of every file: draft-07, the one AsyncAPI 3.0 embeds
#: (``application/schema+json;version=draft-07``); the keywords used mean the same in 2020-12.
DIALECT = "http://json-schema.org/draft-07/schema#"
#: Annotation keywords the schemas carry besides JSON Schema's own (no validation meaning):
#: a strict validator is told them (ajv: ``ajv.addVocabulary(ANNOTATIONS)``, section 10).
ANNOTATIONS: tuple[str, ...] = ("x-topic", "x-unit", "x-dtype", "x-typestr", "x-length",
                                "x-encoding")
_ID_BASE = "https://shipradar.invalid/contract/v{v}/"  # names, not a place to fetch from

# JSON form of one element of a column, by numpy kind
_INT_BOUNDS = {np.dtype(t): (int(np.iinfo(t).min), int(np.iinfo(t).max))
               for t in ("int8", "int16", "int32", "int64", "uint8", "uint16", "uint32",
                         "uint64")}
_ARRAY = re.compile(r"^(bool|u?int(?:8|16|32|64)|float(?:32|64))\[([^\]]+)\]$")
# ``list[str]`` (any length) or ``list[3] float`` (that many)
_LIST = re.compile(r"^list\[(?:(str|int|float)\]|(\d+)\] (str|int|float))$")


def _element(dtype: np.dtype) -> dict[str, Any]:
    if dtype.kind == "b":
        return {"type": "boolean"}
    if dtype.kind in "iu":
        lo, hi = _INT_BOUNDS[dtype]
        return {"type": "integer", "minimum": lo, "maximum": hi}
    # NaN and ±inf have no JSON number: they are null (docs/protocol.md section 5)
    return {"type": ["number", "null"]}


_SCALARS: dict[str, dict[str, Any]] = {
    "str": {"type": "string"}, "int": {"type": "integer"},
    "float": {"type": ["number", "null"]}, "bool": {"type": "boolean"},
    "map": {"type": "object"}}


def _scalar(name: str) -> dict[str, Any] | None:
    return _SCALARS.get(name)


def field_schema(field: Field) -> dict[str, Any]:
    """The JSON Schema of one key, in its decoded JSON form.

    Parameters
    ----------
    field : Field
        A key of :mod:`shipradar.sim.stream.schema`.

    Returns
    -------
    dict
        ``description`` (the meaning), ``x-unit`` when it has one and the type: a scalar, a
        map (object), a list (``list[str]``, ``list[3] float``), or a numpy column
        ``DTYPE[LEN]`` (one array per dimension, ``x-dtype``, ``x-typestr``, ``x-length``).

    Raises
    ------
    ValueError
        For a type string this generator does not know (extend it with the new type).
    """
    out: dict[str, Any] = {"description": field.meaning}
    if field.unit:
        out["x-unit"] = field.unit
    kind = field.type.strip()
    if kind == "map" and field.key == "radar":
        return {**_radar_schema(), **out}
    if kind == "map" and field.keys:
        return {"type": "object", **out,
                "required": [k.key for k in field.keys],
                "properties": {k.key: field_schema(k) for k in field.keys}}
    scalar = _scalar(kind)
    if scalar is not None:
        return {**scalar, **out}
    m = _LIST.match(kind)
    if m is not None:
        any_length, count, item = m.groups()
        item = any_length or item
        schema: dict[str, Any] = {"type": "array", "items": _scalar(item)}
        if count is not None:
            schema.update(minItems=int(count), maxItems=int(count))
        return {**schema, **out}
    m = _ARRAY.match(kind)
    if m is not None:
        dtype = np.dtype(m.group(1))
        dims = [d.strip() for d in m.group(2).split(",")]
        schema = _element(dtype)
        for _ in dims:
            schema = {"type": "array", "items": schema}
        return {**schema, **out, "x-dtype": dtype.name,
                "x-typestr": dtype.newbyteorder("<").str if dtype.itemsize > 1 else dtype.str,
                "x-length": dims[0] if len(dims) == 1 else dims,
                "x-encoding": f"msgpack ext type {EXT_NDARRAY} (docs/protocol.md section 3)"}
    raise ValueError(f"contract: key {field.key!r} has type {field.type!r}, which "
                     "shipradar.sim.stream.contract.field_schema does not know; extend it")


def _inline(node: Any, defs: dict[str, Any]) -> Any:
    """``node`` with every ``{"$ref": "#/$defs/X", ...}`` replaced by definition X (merged
    with the ``$ref``'s sibling keys), recursively: a self-contained schema that reads the
    same inside the AsyncAPI document; ``additionalProperties: false`` dropped."""
    if isinstance(node, dict):
        ref = node.get("$ref")
        if isinstance(ref, str) and ref.startswith("#/$defs/"):
            target = _inline(defs[ref[len("#/$defs/"):]], defs)
            return {**target, **{k: _inline(v, defs) for k, v in node.items() if k != "$ref"}}
        # the scenario refuses unknown keys; a message may carry new ones (section 2)
        return {k: _inline(v, defs) for k, v in node.items()
                if not (k == "additionalProperties" and v is False)}
    if isinstance(node, list):
        return [_inline(v, defs) for v in node]
    return node


def _radar_schema() -> dict[str, Any]:
    """``meta.radar``: the scenario format's radar (its pydantic model, whose field names
    carry their units and whose descriptions their meaning), as JSON Schema (serialised
    form, nested models inlined)."""
    from shipradar.sim.world.scenario import Radar

    raw = Radar.model_json_schema(mode="serialization")
    defs = raw.pop("$defs", {})
    body = _inline(raw, defs)
    body.pop("title", None)
    # a real sensor does not tell its errors (issue 33): the engine leaves them out of meta
    body["properties"].pop("errors", None)
    return body


def schema_file_name(payload: Payload) -> str:
    """``meta.schema.json``, ..., ``truth-plots.schema.json`` (topic and kind)."""
    return payload.name.replace("[", "-").replace("]", "") + ".schema.json"


def payload_schema(payload: Payload) -> dict[str, Any]:
    """The JSON Schema of one payload's decoded body (envelope and payload keys).

    Parameters
    ----------
    payload : Payload
        One of :data:`shipradar.sim.stream.schema.PAYLOADS`.

    Returns
    -------
    dict
        A draft-07 JSON Schema (:data:`DIALECT`).
    """
    props: dict[str, Any] = {
        "v": {"enum": list(SUPPORTED_SCHEMA_VERSIONS),
              "description": f"schema version: {SCHEMA_VERSION} for this contract, the "
              "earlier ones listed still read (docs/protocol.md section 2); refuse another"},
        "t": {"type": "number", "x-unit": "s",
              "description": "simulated time of the message [s since scenario start]"},
    }
    for f in payload.fields:
        props[f.key] = field_schema(f)
    if payload.kind is not None:
        props["kind"] = {**props["kind"], "const": payload.kind}
    topic = payload.topic.decode("ascii")
    return {
        "$schema": DIALECT,
        "$id": _ID_BASE.format(v=SCHEMA_VERSION) + schema_file_name(payload),
        "title": f"shipradar {payload.name} message, schema version {SCHEMA_VERSION}",
        "description": (
            f"Body of a message on topic `{topic}`"
            + (f" with kind `{payload.kind}`" if payload.kind else "")
            + ": one msgpack map, decoded and in its JSON form (numpy columns as lists, NaN "
            "and ±inf as null; docs/protocol.md sections 2-5). Generated from "
            "shipradar.sim.stream.schema; do not edit."),
        "x-topic": topic,
        "type": "object",
        "required": ["v", "t", *(f.key for f in payload.fields if f.required)],
        "properties": props,
        "additionalProperties": True,
        **_required_by_version(payload),
    }


def _required_by_version(payload: Payload) -> dict[str, Any]:
    """``allOf`` of one ``if v = V then required [...]`` per version whose messages carry
    more keys than ``required`` lists (empty for a payload without such keys)."""
    conds = []
    for v in SUPPORTED_SCHEMA_VERSIONS:
        keys = [f.key for f in payload.fields if not f.required and f.required_since is not None
                and f.required_since <= v]
        if keys:
            conds.append({"if": {"properties": {"v": {"const": v}}, "required": ["v"]},
                          # the keys declared beside `required` too (ajv's strictRequired)
                          "then": {"properties": {k: True for k in keys}, "required": keys}})
    return {"allOf": conds} if conds else {}


def _ref_name(payload: Payload) -> str:
    return payload.name.replace("[", "_").replace("]", "")


_CHANNELS = {
    "meta": "Sensor metadata, sent by each radar at t = 0 and at the start of every scan.",
    "plots": "Detections of one sector of one sensor, as columns; one message per sector "
             "that has any plot.",
    "eos": "End of scan: the sensor's own position, velocity and heading.",
    "end": "End of the run: sent once, after every radar's last messages.",
    "truth": "Ground truth (for evaluators, not for the tracker under test): the origin of "
             "each plot (kind `plots`, after each `plots` message), every target's state "
             "(kind `targets`, after each `eos`) and, in a scene with sensor errors, each "
             "radar's errors (kind `sensors`, after `truth[targets]`).",
    "tracks": "A tracker's tracks, published by the tracker on its own endpoint (read by "
              "`shipradar view --tracks`), not by shipradar.",
    "entities": "Entity states a program publishes on its own endpoint for shipradar to "
                "read (`shipradar run SCENARIO --entities ENDPOINT`): an input channel. "
                "shipradar's recording holds the updates a run used on this topic too.",
    "registration": "A tracker's estimates of a radar's errors (range and azimuth biases, "
                    "time-stamp offset), published by the tracker on the endpoint of its "
                    "tracks and scored by `shipradar evaluate` against `truth[sensors]`.",
}
#: Channels shipradar reads (a tracker's tracks and registration, a feed's entities) and the
#: server of each.
_INPUTS = {"tracks": "tracker", "registration": "tracker", "entities": "feed"}


# long: the AsyncAPI document written out literally, one channel per topic
def asyncapi_document() -> dict[str, Any]:
    """The AsyncAPI 3.0 document of the stream: one channel per ZeroMQ topic, its messages'
    payloads the JSON Schemas of :func:`payload_schema` (inlined as components)."""
    schemas: dict[str, Any] = {}
    messages: dict[str, Any] = {}
    channels: dict[str, Any] = {}
    for p in PAYLOADS:
        name = _ref_name(p)
        body = payload_schema(p)
        body.pop("$id")
        schemas[name] = {"schemaFormat": "application/schema+json;version=draft-07",
                         "schema": body}
        messages[name] = {
            "name": name,
            "title": p.name,
            "summary": body["title"],
            "contentType": "application/msgpack",
            "payload": {"$ref": f"#/components/schemas/{name}"},
            "x-schema-file": schema_file_name(p),
        }
        topic = p.topic.decode("ascii")
        ch = channels.setdefault(topic, {
            "address": topic, "title": topic,
            "description": _CHANNELS.get(topic, f"Topic `{topic}` (docs/protocol.md section 4)."),
            "messages": {}})
        ch["messages"][name] = {"$ref": f"#/components/messages/{name}"}
        ch["servers"] = [{"$ref": f"#/servers/{_INPUTS.get(topic, 'shipradar')}"}]
    # one topic, several payloads (truth): a union a code generator can dispatch on, by the
    # key whose value names the payload (AsyncAPI Schema Object's `discriminator`)
    for topic, ch in channels.items():
        kinds = [p for p in PAYLOADS if p.topic.decode("ascii") == topic and p.kind]
        if len(kinds) > 1:
            schemas[topic] = {
                "description": f"Any message on `{topic}`: its key `kind` names which.",
                "discriminator": "kind",
                "oneOf": [{"$ref": f"#/components/schemas/{_ref_name(p)}/schema"}
                          for p in kinds]}
            ch["x-discriminator"] = {"propertyName": "kind", "mapping": {
                p.kind: f"#/components/messages/{_ref_name(p)}" for p in kinds}}
    operations = {}
    for topic, ch in channels.items():
        action = "receive" if topic in _INPUTS else "send"
        operations[f"{action}_{topic}"] = {
            "action": action,
            "channel": {"$ref": f"#/channels/{topic}"},
            "messages": [{"$ref": f"#/channels/{topic}/messages/{m}"} for m in ch["messages"]],
        }
    zmq_note = (
        "ZeroMQ PUB/SUB (ZMTP 3): shipradar binds an XPUB socket, subscribers connect a SUB "
        "socket and subscribe to topic prefixes. Every message is two frames, [topic, body]: "
        "the channel address is the topic frame (ASCII), the body one msgpack map (at most "
        f"{MAX_BODY_BYTES} bytes) whose numpy columns are msgpack extension type "
        f"{EXT_NDARRAY} (docs/protocol.md section 3).")
    return {
        "asyncapi": "3.0.0",
        "id": f"urn:shipradar:stream:v{SCHEMA_VERSION}",
        "info": {
            "title": "shipradar stream",
            "version": str(SCHEMA_VERSION),
            "description": (
                "The stream of a running shipradar (`shipradar run --publish ENDPOINT`, "
                "`shipradar replay FILE --publish ENDPOINT`), seen from shipradar: what it "
                "sends, and the tracks it reads back. The reference is docs/protocol.md; "
                "this document and the JSON Schemas beside it are generated from "
                "shipradar.sim.stream.schema (python -m shipradar.sim.stream.contract "
                "OUTDIR). " + zmq_note),
            "license": {"name": "MIT"},
        },
        "defaultContentType": "application/msgpack",
        "servers": {
            "shipradar": {
                "host": "127.0.0.1:5556", "protocol": "zmq", "protocolVersion": "3.1",
                "title": "shipradar publisher",
                "description": "The endpoint given to --publish (loopback unless secured "
                               "with CurveZMQ, docs/protocol.md sections 1 and 9). "
                               + zmq_note},
            "tracker": {
                "host": "127.0.0.1:5557", "protocol": "zmq", "protocolVersion": "3.1",
                "title": "a tracker's publisher",
                "description": "The endpoint a tracker publishes its tracks (`shipradar view "
                               "--tracks ENDPOINT`) and its registration estimates on."},
            "feed": {
                "host": "127.0.0.1:5560", "protocol": "zmq", "protocolVersion": "3.1",
                "title": "an entity feed's publisher",
                "description": "The endpoint a program publishes entity states on "
                               "(`shipradar run SCENARIO --entities ENDPOINT`); shipradar "
                               "connects a SUB socket and subscribes to `entities`."},
        },
        "channels": channels,
        "operations": operations,
        "components": {"schemas": schemas, "messages": messages},
    }


def contract_files() -> dict[str, str]:
    """Every file of the contract: name -> text (JSON with 2-space indent, YAML)."""
    out = {schema_file_name(p): json.dumps(payload_schema(p), indent=2, ensure_ascii=False)
           + "\n" for p in PAYLOADS}
    header = ("# Generated from shipradar.sim.stream.schema by "
              "`python -m shipradar.sim.stream.contract OUTDIR`; do not edit.\n")
    out[ASYNCAPI_FILE] = header + yaml.safe_dump(asyncapi_document(), sort_keys=False,
                                                 allow_unicode=True, width=100)
    return out


def write_contract(outdir: str | Path) -> list[Path]:
    """Write :func:`contract_files` into ``outdir`` (created if needed).

    Parameters
    ----------
    outdir : str or Path
        Directory to write into; files of the same names are replaced.

    Returns
    -------
    list of Path
        The files written.
    """
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name, text in contract_files().items():
        path = out / name
        path.write_text(text, encoding="utf-8")
        paths.append(path)
    return paths


def contract_dir() -> Path:
    """The shipped contract's directory (``shipradar/sim/stream/contract``, installed as
    package data)."""
    return Path(str(resources.files("shipradar.sim.stream") / "contract"))


if __name__ == "__main__":  # python -m shipradar.sim.stream.contract sim/stream/contract
    if len(sys.argv) != 2:
        sys.exit("usage: python -m shipradar.sim.stream.contract OUTDIR")
    for p in write_contract(sys.argv[1]):
        print(p)
