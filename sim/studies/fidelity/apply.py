"""``shipradar fidelity --apply``: the scenario file with its ``fidelity:`` block replaced,
validated before anything is written, and written atomically.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from shipradar.sim.studies.fidelity.report import fidelity_yaml
from shipradar.sim.world.scenario import Fidelity, ScenarioError


def apply_fidelity(scenario_path: Path, fid: dict[str, Any], out: Path, *,
                   overwrite: bool = False, unread: Sequence[str] = ()) -> Path | None:
    """Write the scenario file with its ``fidelity:`` block replaced by ``fid``.

    ``unread``: choices the scene does not read under ``fid``, left out of the block
    (:func:`fidelity_yaml`; the schema's defaults then stand for them, unread).

    Everything else of the file is kept as written (comments included): a top-level
    ``fidelity:`` block is replaced in place, else the block is appended. The result is
    validated before anything is written, and written atomically. An existing ``out`` is
    refused unless ``overwrite``; then its former content is first kept beside it as
    ``OUT.bak`` (``OUT.bak.1``, ... if that exists), so nothing is lost.

    Returns
    -------
    Path or None
        The backup written, if any.

    Raises
    ------
    FileExistsError
        ``out`` exists and ``overwrite`` is False.
    ScenarioError
        The result does not validate.
    """
    from shipradar.sim.world.scenario import load_scenario

    text = Path(scenario_path).read_text(encoding="utf-8")
    lines = text.splitlines(keepends=True)
    block = fidelity_yaml(fid, unread)
    start = next((i for i, ln in enumerate(lines) if ln.startswith("fidelity:")), None)
    if start is None:
        new = text + ("" if text.endswith("\n") or not text else "\n") + block
    else:
        end = start + 1
        while end < len(lines) and (not lines[end].strip() or lines[end][0] in " \t#"):
            end += 1
        # trailing blank/comment lines belong to what follows
        while end > start + 1 and (not lines[end - 1].strip()
                                   or lines[end - 1].lstrip().startswith("#")):
            end -= 1
        new = "".join(lines[:start]) + block + "".join(lines[end:])
    out = Path(out)
    if out.exists() and not overwrite:
        raise FileExistsError(f"--apply: {out} exists; pass --overwrite to replace it (its "
                              "content is then kept as a .bak file)")
    fd, tmp = tempfile.mkstemp(dir=out.parent if str(out.parent) else ".",
                               prefix=f".{out.name}.", suffix=".tmp")
    backup = None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(new)
        check = load_scenario(tmp)  # raises ScenarioError: nothing written
        read = set(Fidelity.model_fields) - set(unread)
        if check.fidelity.model_dump(include=read) != Fidelity(**fid).model_dump(include=read):
            raise ScenarioError(["--apply: the fidelity block did not round-trip"])
        if out.exists():
            backup = out.with_name(out.name + ".bak")
            n = 1
            while backup.exists():
                backup = out.with_name(f"{out.name}.bak.{n}")
                n += 1
            try:
                os.link(out, backup)  # the old file itself, kept under the new name
            except OSError:  # a file system without hard links
                backup.write_bytes(out.read_bytes())
        os.replace(tmp, out)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return backup
