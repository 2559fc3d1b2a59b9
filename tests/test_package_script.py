"""scripts/package_models.py's model defaults: the refinement from two reports, the plane removal and
the box growth and the face alignment from category lists, the other defaults kept."""

from __future__ import annotations

import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))

from package_models import RESTARTS_ON, set_defaults  # noqa: E402


def _report(rot, success, iou):
    return {"parts": {"rotation_deg": {"mean": rot}, "iou": {"mean": iou}}, "success": {"fraction": success}}


def test_defaults_from_reports_and_lists_keep_the_others(tmp_path):
    (tmp_path / "drawer_norefine.json").write_text(json.dumps(_report([10.0, 12.0], 0.2, [0.6, 0.5])))
    (tmp_path / "drawer_refine.json").write_text(json.dumps(_report([9.0, 10.0], 0.3, [0.6, 0.5])))
    info = {"defaults": {"denoise_above_m": 0.002}}
    set_defaults(
        info,
        tmp_path,
        "drawer",
        remove_plane=["mug"],
        grow_boxes=["drawer", "laptop"],
        align_faces=["drawer"],
        wide_scale_search=["mug"],
        fit_extents=["drawer"],
        free_space=["laptop"],
    )
    d = info["defaults"]
    assert d["refine"] is True and d["remove_plane"] is False and d["grow_boxes"] is True and d["align_faces"] is True
    assert d["wide_scale_search"] is False and d["fit_extents"] is True and d["free_space"] is False
    assert d["denoise_above_m"] == 0.002 and d["decided_from"] == ["drawer_norefine.json", "drawer_refine.json"]
    set_defaults(info, tmp_path, "drawer", grow_boxes=[])  # an empty list turns it off; omitted lists leave it
    assert info["defaults"]["grow_boxes"] is False and info["defaults"]["remove_plane"] is False
    assert info["defaults"]["align_faces"] is True
    other = {}
    set_defaults(other, tmp_path, "mug")  # no reports, no lists: nothing to set
    assert other == {}
    set_defaults(info, tmp_path, "drawer", restarts=["drawer"])  # a count, not a switch
    assert info["defaults"]["restarts"] == RESTARTS_ON and info["defaults"]["grow_boxes"] is False
    set_defaults(info, tmp_path, "drawer", restarts=["mug"])
    assert info["defaults"]["restarts"] == 0
