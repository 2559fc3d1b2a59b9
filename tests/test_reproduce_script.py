"""scripts/reproduce_models.sh stays true to what ships: each of its per-category lists names exactly the
shipped models whose defaults have that step on."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
SCRIPT = (ROOT / "scripts" / "reproduce_models.sh").read_text()
SHIPPED = {
    p.stem: json.loads(p.read_text())["info"].get("defaults", {}) for p in (ROOT / "src" / "ucope" / "pretrained").glob("*.json")
}

LISTS = {  # the script's variable -> whether a shipped model's defaults have the step on
    "PLANE_CATS": lambda d: bool(d.get("remove_plane", False)),
    "DENOISE_CATS": lambda d: d.get("denoise_above_m") is not None,
    "GROW_CATS": lambda d: bool(d.get("grow_boxes", False)),
    "ALIGN_CATS": lambda d: bool(d.get("align_faces", False)),
    "WIDE_CATS": lambda d: bool(d.get("wide_scale_search", False)),
    "FIT_CATS": lambda d: bool(d.get("fit_extents", False)),
    "ANCHOR_CATS": lambda d: bool(d.get("anchor_faces", False)),
    "FREE_CATS": lambda d: bool(d.get("free_space", False)),
    "SEAT_CATS": lambda d: bool(d.get("seat_parts", False)),
    "SLIDE_CATS": lambda d: bool(d.get("free_slides", False)),
    "PICK_CATS": lambda d: bool(d.get("pick_seen_parts", False)),
    "CONE_CATS": lambda d: bool(d.get("carry_in_cone", False)),
    "RESTART_CATS": lambda d: int(d.get("restarts", 0)) > 0,
}


def script_list(var: str) -> set[str]:
    """The categories of ``VAR=${VAR-"..."}`` in the script."""
    m = re.search(rf'^{var}=\$\{{{var}-"([^"]*)"\}}', SCRIPT, re.M)
    assert m, f"{var} is not set in reproduce_models.sh"
    return set(m.group(1).split())


@pytest.mark.parametrize("var", sorted(LISTS))
def test_each_list_names_the_shipped_models_with_that_step_on(var):
    assert len(SHIPPED) == 11
    on = {c for c, d in SHIPPED.items() if LISTS[var](d)}
    assert script_list(var) == on


def test_every_list_reaches_the_packaging():
    """Both package_models.py calls that set defaults (``--set-defaults`` per run, and the packaging) pass every
    switch list; the ``--figures-only`` refresh passes none and leaves the defaults as they are."""
    calls = re.findall(r"package_models\.py (?:[^\n]*\\\n)*[^\n]*", SCRIPT)
    setting = [c for c in calls if "--figures-only" not in c]
    assert len(calls) == 3 and len(setting) == 2
    flags = [("--remove-plane", "PLANE_CATS"), ("--grow-boxes", "GROW_CATS"), ("--align-faces", "ALIGN_CATS")]
    flags += [("--wide-scale-search", "WIDE_CATS"), ("--fit-extents", "FIT_CATS"), ("--anchor-faces", "ANCHOR_CATS")]
    flags += [("--free-space", "FREE_CATS"), ("--seat-parts", "SEAT_CATS"), ("--free-slides", "SLIDE_CATS")]
    flags += [("--pick-seen-parts", "PICK_CATS"), ("--carry-in-cone", "CONE_CATS"), ("--restarts", "RESTART_CATS")]
    for call in setting:
        for flag, var in flags:
            assert f"{flag} ${var}" in call, (flag, call)
