"""Tests for ucope.eval.mean_ap: hand-built cases, order-freedom, and the reference figures of both protocols.

``test_*_reference_figures`` are regression tests in the style of the BOP toolkit: the mAP of a fixed set
of records compared with figures computed once by an independent implementation of the NOCS reference
algorithm written from its published description (tests/eval/nocs_reference.py), stored below.
"""

from __future__ import annotations

import itertools
import json
import random

import numpy as np
import pytest
from nocs_reference import compute_3d_iou_new, nocs_map
from scipy.spatial.transform import Rotation

from ucope.errors import InputError
from ucope.eval.mean_ap import (
    average_precision,
    compute_map,
    max_matching_size,
    nocs_average_precision,
    nocs_reference_iou,
    tie_range,
)
from ucope.geometry.boxes import box_iou_3d
from ucope.geometry.transforms import make_transform, rotation_about_axis

X, Y, Z = np.eye(3)
METRICS = ["3D50", "3D75", "5deg2cm", "5deg5cm", "10deg2cm", "10deg5cm"]


def rot(axis, deg: float) -> np.ndarray:
    return rotation_about_axis(np.asarray(axis, dtype=float), np.radians(deg))


def pose(R=None, t=(0.0, 0.0, 1.0)) -> np.ndarray:
    return make_transform(np.eye(3) if R is None else R, np.asarray(t, dtype=float))


# --------------------------------------------------------------------------------------------------
# hand-built cases
# --------------------------------------------------------------------------------------------------


def test_average_precision_hand_cases():
    # sorted: TP, FP, TP, TP with 3 GT: precisions 1, 1/2, 2/3, 3/4 at recalls 1/3, 1/3, 2/3, 1;
    # envelope 1, 3/4, 3/4 -> AP = 1/3 * 1 + 1/3 * 3/4 + 1/3 * 3/4 = 5/6
    assert average_precision([1, 1, 0, 1], [0.7, 0.9, 0.8, 0.6], 3) == pytest.approx(5 / 6)  # unsorted input
    assert average_precision([True, True], [0.2, 0.1], 2) == pytest.approx(1.0)
    assert average_precision([1, 1], [0.2, 0.1], 4) == pytest.approx(0.5)  # recall never reaches 1
    assert average_precision([], [], 3) == 0.0
    assert average_precision([0, 0], [0.5, 0.4], 1) == 0.0


def cube_gt(t, size=0.1):
    return {"class": "camera", "cam_from_object": pose(None, t), "size_m": [size] * 3}


def test_compute_map_hand_built_set():
    """Worked by hand.

    camera (0.1 m cubes): image 0 has gt0 at (0, 0, 1); image 1 has gt1 at (-0.3, 0, 1) and gt2 at (0.3, 0, 1);
    image 2 has no camera. Predictions by descending score:
      e 0.95 image 2, on gt0's pose          -> FP everywhere (no GT in its image)
      a 0.90 image 0, = gt0                  -> IoU 1, 0 deg, 0 cm
      b 0.80 image 0, = gt0 (duplicate)      -> FP everywhere (gt0 already taken by a)
      c 0.70 image 1, gt1 moved 3 cm along x -> IoU 0.07 / 0.13 = 0.538, 0 deg, 3 cm
      d 0.60 image 1, gt2 turned 90 deg about z -> IoU 1 (a cube), 90 deg, 0 cm
    With 3 GT (recall steps of 1/3):
      3D50:  FP TP FP TP TP: precisions 0 .5 .33 .5 .6 -> envelope .6 at recalls 1/3, 2/3, 1 -> AP 0.6
      3D75:  FP TP FP FP TP: precisions 0 .5 .33 .25 .4 -> .5 at 1/3, .4 at 2/3 -> AP (.5 + .4) / 3 = 0.3
      5deg2cm, 10deg2cm: only a -> .5 at 1/3 -> AP 1/6
      5deg5cm, 10deg5cm: a and c: precisions 0 .5 .33 .5 .4 -> .5 at 1/3 and 2/3 -> AP 1/3
    bottle (symmetric about y): one GT, one prediction turned 40 deg about y -> 0 deg, IoU 1: AP 1 everywhere.
    can: a prediction but no GT -> AP None, left out of the mean.
    Mean over camera and bottle: 3D50 0.8, 3D75 0.65, x deg 2cm 7/12, x deg 5cm 2/3.
    """
    bottle_T = pose(rot(X, 20), (0.0, 0.3, 1.2))
    bottle_size = [0.06, 0.2, 0.08]
    records = [
        {
            "gt": [cube_gt((0, 0, 1)), {"class": "bottle", "cam_from_object": bottle_T, "size_m": bottle_size}],
            "pred": [
                {**cube_gt((0, 0, 1)), "score": 0.9},
                {**cube_gt((0, 0, 1)), "score": 0.8},
                {
                    "class": "bottle",
                    "cam_from_object": bottle_T @ pose(rot(Y, 40), (0, 0, 0)),
                    "size_m": bottle_size,
                    "score": 0.5,
                },
            ],
        },
        {
            "gt": [cube_gt((-0.3, 0, 1)), cube_gt((0.3, 0, 1))],
            "pred": [
                {**cube_gt((-0.27, 0, 1)), "score": 0.7},
                {"class": "camera", "cam_from_object": pose(rot(Z, 90), (0.3, 0, 1)), "size_m": [0.1] * 3, "score": 0.6},
            ],
        },
        {
            "gt": [],
            "pred": [
                {**cube_gt((0, 0, 1)), "score": 0.95},
                {"class": "can", "cam_from_object": pose(), "size_m": [0.07, 0.12, 0.07], "score": 0.9},
            ],
        },
    ]
    res = compute_map(records)
    json.dumps(res, allow_nan=False)
    assert "exact" in res["iou_method"] and "axis-aligned" in res["iou_method"]
    assert res["metrics"] == ["3D50", "3D75", "5deg2cm", "5deg5cm", "10deg2cm", "10deg5cm"]
    cam = res["per_class"]["camera"]
    assert cam["3D50"] == pytest.approx(0.6)
    assert cam["3D75"] == pytest.approx(0.3)
    assert cam["5deg2cm"] == pytest.approx(1 / 6) and cam["10deg2cm"] == pytest.approx(1 / 6)
    assert cam["5deg5cm"] == pytest.approx(1 / 3) and cam["10deg5cm"] == pytest.approx(1 / 3)
    assert all(v == pytest.approx(1.0) for v in res["per_class"]["bottle"].values())
    assert all(v is None for v in res["per_class"]["can"].values())
    assert res["num_gt"] == {"bottle": 1, "camera": 3, "can": 0}
    assert res["num_pred"] == {"bottle": 1, "camera": 5, "can": 1}
    assert res["classes_with_gt"] == ["bottle", "camera"]
    expected_mean = {"3D50": 0.8, "3D75": 0.65, "5deg2cm": 7 / 12, "5deg5cm": 2 / 3, "10deg2cm": 7 / 12, "10deg5cm": 2 / 3}
    for name, value in expected_mean.items():
        assert res["mean"][name] == pytest.approx(value), name

    # NOCS reference gating (opt-in): pose APs only over the pairs matched at IoU >= 0.1, i.e. predictions
    # a, c, d and all 3 GT (e and b are dropped, not false positives): 5deg2cm TP FP FP -> 1/3,
    # 5deg5cm TP TP FP -> 2/3; the IoU metrics do not change.
    gated = compute_map(records, pose_iou_gate=0.1)
    cam = gated["per_class"]["camera"]
    assert cam["5deg2cm"] == pytest.approx(1 / 3) and cam["10deg2cm"] == pytest.approx(1 / 3)
    assert cam["5deg5cm"] == pytest.approx(2 / 3) and cam["10deg5cm"] == pytest.approx(2 / 3)
    assert cam["3D50"] == pytest.approx(0.6) and cam["3D75"] == pytest.approx(0.3)
    assert gated["pose_iou_gate"] == 0.1 and res["pose_iou_gate"] is None


def test_compute_map_greedy_match_takes_the_best_gt():
    """1 m cubes: gt1 at x = 0, gt2 at x = 0.3 in one image.

    p1 (score 0.9) at x = 0.2: IoU 0.8/1.2 = 0.67 with gt1 and 0.9/1.1 = 0.82 with gt2; 20 cm and 10 cm away.
    p2 (score 0.8) at x = 0.35: IoU 0.95/1.05 with gt2 but 0.65/1.35 = 0.48 < 0.5 with gt1; 5 cm and 35 cm away.
    p1 must take gt2 (best IoU / smallest error), leaving p2 unmatched: TP, FP with 2 GT -> AP 0.5.
    (Taking the first passing GT, gt1, or matching p2 first, would give AP 1.)
    """
    gts = [{"class": "camera", "cam_from_object": pose(None, (x, 0, 3)), "size_m": [1, 1, 1]} for x in (0.0, 0.3)]
    preds = [
        {"class": "camera", "cam_from_object": pose(None, (x, 0, 3)), "size_m": [1, 1, 1], "score": s}
        for x, s in ((0.35, 0.8), (0.2, 0.9))
    ]  # listed in the wrong order: matching must sort by score
    res = compute_map([{"gt": gts, "pred": preds}], iou_thresholds=[0.5], pose_thresholds_deg_cm=[(5, 30)])
    assert res["metrics"] == ["3D50", "5deg30cm"]
    assert res["per_class"]["camera"]["3D50"] == pytest.approx(0.5)
    assert res["per_class"]["camera"]["5deg30cm"] == pytest.approx(0.5)


def test_compute_map_pose_gate_drops_undetected_gt():
    # two GT cameras, one exact prediction: ungated, recall stops at 1/2 (AP 0.5); gated, the missed GT is
    # dropped from the pose evaluation as in the NOCS reference code (AP 1)
    rec = [{"gt": [cube_gt((0, 0, 1)), cube_gt((0.5, 0, 1))], "pred": [{**cube_gt((0, 0, 1)), "score": 1.0}]}]
    assert compute_map(rec)["mean"]["5deg2cm"] == pytest.approx(0.5)
    assert compute_map(rec, pose_iou_gate=0.1)["mean"]["5deg2cm"] == pytest.approx(1.0)
    assert compute_map(rec, pose_iou_gate=0.1)["mean"]["3D50"] == pytest.approx(0.5)


def test_compute_map_mug_handle_special_case():
    size = [0.12, 0.1, 0.09]
    T = pose(None, (0.0, 0.0, 0.8))
    pred = {"class": "mug", "cam_from_object": T @ pose(rot(Y, 30), (0, 0, 0)), "size_m": size, "score": 1.0}
    hidden = compute_map(
        [{"gt": [{"class": "mug", "cam_from_object": T, "size_m": size, "handle_visible": False}], "pred": [pred]}],
        iou_thresholds=[0.75],
    )
    visible = compute_map(
        [{"gt": [{"class": "mug", "cam_from_object": T, "size_m": size}], "pred": [pred]}], iou_thresholds=[0.75]
    )
    # handle not visible: symmetric about y, the 30 degree turn costs nothing
    assert hidden["mean"]["5deg2cm"] == pytest.approx(1.0)
    assert hidden["mean"]["3D75"] == pytest.approx(1.0)
    # handle visible (the default): a 30 degree error
    assert visible["mean"]["10deg5cm"] == 0.0


# --------------------------------------------------------------------------------------------------
# ties: order-free, the lowest AP over the tie orders, and the score-free fraction
# --------------------------------------------------------------------------------------------------


def test_tied_scores_form_one_operating_point():
    # all tied: one point at recall 3/4, precision 3/5 -> AP = 3/4 * 3/5, whatever the order
    assert average_precision([1, 0, 1, 0, 1], [1.0] * 5, 4) == pytest.approx(0.45)
    assert average_precision([0, 1, 0, 1, 1], [1.0] * 5, 4) == pytest.approx(0.45)
    # a tie in the middle: 0.9 TP, then {0.5: TP, FP}, then 0.1 TP; 3 GT
    # points (1/3, 1), (2/3, 2/3), (1, 3/4): AP = 1/3 + 1/3 * 3/4 + 1/3 * 3/4 = 5/6
    assert average_precision([1, 1, 0, 1], [0.9, 0.5, 0.5, 0.1], 3) == pytest.approx(5 / 6)
    assert average_precision([1, 0, 1, 1], [0.9, 0.5, 0.5, 0.1], 3) == pytest.approx(5 / 6)


def test_tied_ap_is_the_lowest_and_tie_range_spans_every_order():
    """Brute force over every order of the tied detections, as the reference ranking could produce them."""
    rng = np.random.default_rng(3)
    for _ in range(25):
        n = int(rng.integers(1, 7))
        scores = rng.choice([0.2, 0.5, 0.9], size=n)
        tp = rng.integers(0, 2, size=n)
        num_gt = int(tp.sum() + rng.integers(1, 3))
        values = set()
        for perm in itertools.permutations(range(n)):
            p = np.array(perm)
            values.add(round(nocs_average_precision(tp[p], scores[p], num_gt), 12))
        low, high = tie_range(tp, scores, num_gt)
        assert average_precision(tp, scores, num_gt) == pytest.approx(min(values), abs=1e-12) == pytest.approx(low)
        assert high == pytest.approx(max(values), abs=1e-12)


def _baseline_like_records(n=12, passing=(0, 1, 2, 3, 4)):
    """One camera per view, every score 1.0 (as the regression baseline gave); views in `passing` are exact,
    the others 6 cm off (3D75 and 5deg2cm misses, 3D50 hit)."""
    records = []
    for i in range(n):
        t = (0.05 * i, 0.0, 1.0)
        shift = (0.0, 0.0, 0.0) if i in passing else (0.0, 0.0, 0.06)
        records.append(
            {
                "gt": [{"class": "camera", "cam_from_object": pose(None, t), "size_m": [0.3, 0.3, 0.3]}],
                "pred": [
                    {
                        "class": "camera",
                        "cam_from_object": pose(rot(Y, 1.0), np.add(t, shift)),
                        "size_m": [0.3, 0.3, 0.3],
                        "score": 1.0,
                    }
                ],
            }
        )
    return records


def test_map_does_not_depend_on_record_order():
    """With tied scores (the baseline's 1.0 everywhere) a stable sort made the AP depend on the record order:
    passing views first gave 3D75 = 5/12, last gave (5/12)^2.  Now no permutation of the records, or of the
    objects inside a record, changes any figure."""
    records = _baseline_like_records()
    ref = compute_map(records)
    assert ref["per_class"]["camera"]["3D75"] == pytest.approx((5 / 12) ** 2)
    assert ref["fraction"]["per_class"]["camera"]["3D75"] == pytest.approx(5 / 12)
    assert ref["tie_range"]["per_class"]["camera"]["3D75"] == pytest.approx([(5 / 12) ** 2, 5 / 12])
    assert ref["num_tied"] == {"camera": 12}
    shuffler = random.Random(0)
    for trial in range(4):
        recs = [dict(r) for r in (records[::-1] if trial == 0 else shuffler.sample(records, len(records)))]
        assert compute_map(recs) == ref


def test_map_is_order_free_with_several_objects_per_image():
    """Two tied predictions in one image competing for the same GT: who gets it must not follow list order."""
    gts = [{"class": "camera", "cam_from_object": pose(None, (x, 0, 3)), "size_m": [1, 1, 1]} for x in (0.0, 0.3)]
    # p1 passes only gt1 at 3D50; p2 passes both but prefers gt1 (higher IoU)
    preds = [
        {"class": "camera", "cam_from_object": pose(None, (x, 0, 3)), "size_m": [1, 1, 1], "score": 0.7} for x in (-0.25, 0.1)
    ]
    records = [{"gt": gts, "pred": preds}, {"gt": gts[:1], "pred": [dict(preds[1], score=0.9)]}]
    ref = compute_map(records, iou_thresholds=[0.5], pose_thresholds_deg_cm=[(5, 20)])
    for g, p in itertools.product(itertools.permutations(gts), itertools.permutations(preds)):
        recs = [{"gt": list(g), "pred": list(p)}, records[1]]
        assert compute_map(recs, iou_thresholds=[0.5], pose_thresholds_deg_cm=[(5, 20)]) == ref
        assert compute_map(recs[::-1], iou_thresholds=[0.5], pose_thresholds_deg_cm=[(5, 20)]) == ref


def test_score_free_fraction_is_the_best_reachable_recall():
    # one image, two GT, three predictions: p0 passes g0 and g1, p1 passes g0 only, p2 nothing -> 2 of 2
    assert max_matching_size([[True, True], [True, False], [False, False]]) == 2
    assert max_matching_size([[True, False], [True, False]]) == 1
    assert max_matching_size(np.zeros((0, 3), bool)) == 0
    res = compute_map(_baseline_like_records(passing=(1, 4, 7)))
    frac = res["fraction"]["per_class"]["camera"]
    assert frac["3D50"] == 1.0 and frac["3D75"] == pytest.approx(3 / 12) and frac["5deg2cm"] == pytest.approx(3 / 12)
    assert res["fraction"]["mean"] == frac


# --------------------------------------------------------------------------------------------------
# the NOCS protocol
# --------------------------------------------------------------------------------------------------


def test_nocs_reference_iou_matches_the_reference_layout():
    """Our (8, 3)-corner version of the defect against the reference's (3, 8) layout, and what it is not."""
    rng = np.random.default_rng(5)
    for symmetric in (False, True):
        for _ in range(10):
            R = Rotation.random(random_state=int(rng.integers(1 << 30))).as_matrix()
            Tg = make_transform(R, rng.uniform(-0.2, 0.2, 3) + [0, 0, 1])
            sg = rng.uniform(0.05, 0.3, 3)
            Tp = Tg @ make_transform(rot(rng.normal(size=3), rng.uniform(0, 30)), rng.normal(0, 0.02, 3))
            sp = sg * rng.uniform(0.8, 1.2, 3)
            name = "can" if symmetric else "camera"
            expected = compute_3d_iou_new(Tp, Tg, sp, sg, 1, name, name)
            assert nocs_reference_iou(Tp, sp, Tg, sg, symmetric=symmetric) == pytest.approx(expected, abs=1e-12)
    T = pose(rot([1, 2, 3], 40.0))
    assert nocs_reference_iou(T, [0.2, 0.1, 0.3], T, [0.2, 0.1, 0.3]) == pytest.approx(1.0)
    with pytest.raises(InputError, match="size_pred"):
        nocs_reference_iou(T, [0.2, 0.0, 0.3], T, [0.2, 0.1, 0.3])


def test_the_worked_example_of_docs_metrics_md():
    """docs/metrics.md's example: a 0.3 x 0.05 x 0.2 m box turned 45 degrees about y, 1 m in front of the camera,
    and a prediction turned 20 or 45 degrees further: exact IoU, the axis-aligned IoU the reference code meant
    to compute, and what it returns; the last also moves with the box (0.1, -0.05, 0.8 m)."""
    from pathlib import Path

    from ucope.geometry.boxes import box_corners

    def axis_aligned(Ta, sa, Tb, sb):  # the intended reference IoU: boxes enclosing the corners, camera axes
        ca, cb = box_corners(Ta, sa), box_corners(Tb, sb)
        overlap = np.clip(np.minimum(ca.max(0), cb.max(0)) - np.maximum(ca.min(0), cb.min(0)), 0.0, None)
        inter = np.prod(overlap)
        return inter / (np.prod(np.ptp(ca, axis=0)) + np.prod(np.ptp(cb, axis=0)) - inter)

    size = [0.3, 0.05, 0.2]
    rows = []
    for t in ((0.0, 0.0, 1.0), (0.1, -0.05, 0.8)):
        gt = pose(rot(Y, 45.0), t)
        for extra in (20.0, 45.0):
            pred = pose(rot(Y, 45.0 + extra), t)
            rows.append(
                [box_iou_3d(pred, size, gt, size), axis_aligned(pred, size, gt, size), nocs_reference_iou(pred, size, gt, size)]
            )
    expected = [[0.756, 0.865, 0.698], [0.639, 0.480, 0.445], [0.756, 0.865, 0.749], [0.639, 0.480, 0.527]]
    assert np.round(rows, 3).tolist() == expected
    doc = (Path(__file__).resolve().parents[2] / "docs" / "metrics.md").read_text()
    for r in expected[:2]:
        assert "| " + " | ".join(f"{v:.3f}" for v in r) + " |" in doc
    assert "0.749" in doc and "0.527" in doc


def test_nocs_ranking_follows_the_record_order_on_ties():
    """The reference protocol is reproduced with its flaw: on tied scores the AP depends on the order of the
    records (ties are ranked last record first), always within the tie range."""
    records = _baseline_like_records()
    first = compute_map(records, protocol="nocs")["per_class"]["camera"]["3D75"]
    last = compute_map(records[::-1], protocol="nocs")["per_class"]["camera"]["3D75"]
    assert last == pytest.approx(5 / 12)  # reversed: the passing views are read first
    assert first < last
    low, high = compute_map(records, protocol="nocs")["tie_range"]["per_class"]["camera"]["3D75"]
    assert low <= first <= high and high == pytest.approx(5 / 12)


def test_nocs_protocol_gates_pose_metrics_at_iou_above_a_tenth():
    rec = [{"gt": [cube_gt((0, 0, 1)), cube_gt((0.5, 0, 1))], "pred": [{**cube_gt((0, 0, 1.001)), "score": 1.0}]}]
    res = compute_map(rec, protocol="nocs")
    assert res["mean"]["5deg2cm"] == pytest.approx(1.0)  # the missed GT is dropped, as the reference does
    assert res["mean"]["3D50"] == pytest.approx(0.5)
    assert res["protocol"] == "nocs" and res["pose_iou_gate"] == 0.1 and "wrong array axis" in res["iou_method"]
    with pytest.raises(InputError, match="pose_iou_gate"):
        compute_map(rec, protocol="nocs", pose_iou_gate=0.2)
    with pytest.raises(InputError, match="protocol"):
        compute_map(rec, protocol="bop")


# --------------------------------------------------------------------------------------------------
# reference figures (BOP-toolkit style regression tests)
# --------------------------------------------------------------------------------------------------

SIZES = {
    "bottle": (0.07, 0.2, 0.07),
    "bowl": (0.16, 0.07, 0.16),
    "camera": (0.12, 0.09, 0.08),
    "can": (0.07, 0.12, 0.07),
    "laptop": (0.32, 0.22, 0.26),
    "mug": (0.13, 0.1, 0.09),
}


def fixed_records():
    """12 images of 1-3 objects with noisy, flipped, duplicate, missing and stray predictions, hidden and
    visible mug handles; distinct scores.  Deterministic: numpy's legacy RandomState stream is frozen."""
    rs = np.random.RandomState(2024)
    classes = sorted(SIZES)
    records = []
    for _ in range(12):
        gts, preds = [], []
        for _ in range(rs.randint(1, 4)):
            cls = classes[rs.randint(len(classes))]
            R = Rotation.from_rotvec(rs.normal(size=3) * 0.6).as_matrix()
            T = np.eye(4)
            T[:3, :3], T[:3, 3] = R, [rs.uniform(-0.3, 0.3), rs.uniform(-0.2, 0.2), rs.uniform(0.6, 1.2)]
            size = np.array(SIZES[cls]) * rs.uniform(0.8, 1.2, 3)
            gt = {"class": cls, "cam_from_object": T.tolist(), "size_m": size.tolist()}
            if cls == "mug":
                gt["handle_visible"] = bool(rs.rand() < 0.5)
            gts.append(gt)
            for _ in range(rs.choice([0, 1, 1, 1, 2])):  # missed, found, or found twice
                dR = Rotation.from_rotvec(rs.normal(size=3) * np.radians(rs.choice([2.0, 4.0, 8.0, 20.0]))).as_matrix()
                if rs.rand() < 0.15:  # a half-turn flip about y
                    dR = dR @ Rotation.from_rotvec([0.0, np.pi, 0.0]).as_matrix()
                P = np.eye(4)
                P[:3, :3] = R @ dR
                P[:3, 3] = T[:3, 3] + rs.normal(size=3) * rs.choice([0.005, 0.015, 0.03])
                preds.append(
                    {
                        "class": cls,
                        "cam_from_object": P.tolist(),
                        "size_m": (size * rs.uniform(0.85, 1.15, 3)).tolist(),
                        "score": float(rs.uniform(0.05, 1.0)),
                    }
                )
        if rs.rand() < 0.4:  # a stray prediction of some class
            cls = classes[rs.randint(len(classes))]
            P = np.eye(4)
            P[:3, :3] = Rotation.from_rotvec(rs.normal(size=3)).as_matrix()
            P[:3, 3] = [rs.uniform(-0.3, 0.3), rs.uniform(-0.2, 0.2), rs.uniform(0.6, 1.2)]
            preds.append(
                {"class": cls, "cam_from_object": P.tolist(), "size_m": list(SIZES[cls]), "score": float(rs.uniform(0.05, 1.0))}
            )
        records.append({"gt": gts, "pred": preds})
    return records


# Computed once by tests/eval/nocs_reference.py on fixed_records(); per class: 3D50, 3D75, 5deg2cm, 5deg5cm,
# 10deg2cm, 10deg5cm.  nocs_map(records) (the published protocol):
NOCS_FIGURES = {
    "bottle": [0.750000000000, 0.750000000000, 0.250000000000, 0.250000000000, 0.250000000000, 0.250000000000],
    "bowl": [0.685714285714, 0.395238095238, 0.000000000000, 0.333333333333, 0.000000000000, 0.333333333333],
    "camera": [0.666666666667, 0.666666666667, 0.500000000000, 0.500000000000, 1.000000000000, 1.000000000000],
    "can": [0.933333333333, 0.666666666667, 0.000000000000, 0.000000000000, 0.280000000000, 0.280000000000],
    "laptop": [0.750000000000, 0.416666666667, 0.000000000000, 0.333333333333, 0.000000000000, 0.333333333333],
    "mug": [0.644897959184, 0.514285714286, 0.040000000000, 0.160000000000, 0.160000000000, 0.160000000000],
}
# nocs_map(records, iou="exact", use_matches_for_pose=False) (the same pipeline, exact IoU, no gating):
EXACT_FIGURES = {
    "bottle": [0.500000000000, 0.500000000000, 0.500000000000, 0.500000000000, 0.500000000000, 0.500000000000],
    "bowl": [0.133333333333, 0.000000000000, 0.000000000000, 0.309523809524, 0.000000000000, 0.309523809524],
    "camera": [0.666666666667, 0.166666666667, 0.333333333333, 0.333333333333, 0.666666666667, 0.666666666667],
    "can": [0.500000000000, 0.000000000000, 0.000000000000, 0.000000000000, 0.266666666667, 0.266666666667],
    "laptop": [0.750000000000, 0.000000000000, 0.000000000000, 0.250000000000, 0.000000000000, 0.250000000000],
    "mug": [0.514285714286, 0.000000000000, 0.028571428571, 0.214285714286, 0.114285714286, 0.214285714286],
}


def _assert_figures(per_class, mean, stored):
    assert sorted(per_class) == sorted(stored)
    for cls, values in stored.items():
        assert [per_class[cls][m] for m in METRICS] == pytest.approx(values, abs=1e-11), cls
    for k, m in enumerate(METRICS):
        assert mean[m] == pytest.approx(np.mean([v[k] for v in stored.values()]), abs=1e-11), m


@pytest.mark.parametrize("protocol, stored", [("nocs", NOCS_FIGURES), ("exact", EXACT_FIGURES)])
def test_map_reproduces_the_reference_figures(protocol, stored):
    res = compute_map(fixed_records(), protocol=protocol)
    _assert_figures(res["per_class"], res["mean"], stored)
    assert res["num_tied"] == dict.fromkeys(stored, 0)


@pytest.mark.parametrize("iou, gate, stored", [("nocs", True, NOCS_FIGURES), ("exact", False, EXACT_FIGURES)])
def test_the_reference_implementation_still_gives_the_stored_figures(iou, gate, stored):
    per_class, mean = nocs_map(fixed_records(), iou=iou, use_matches_for_pose=gate)
    _assert_figures(per_class, mean, stored)


# --------------------------------------------------------------------------------------------------
# bad inputs
# --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: average_precision([1, 0], [0.5], 1), "scores"),
        (lambda: average_precision([1, 1], [0.5, 0.4], 1), "true positives"),
        (lambda: average_precision([1], [0.5], 0), "num_gt"),
        (lambda: average_precision([2], [0.5], 2), "tp"),
        (lambda: compute_map({"gt": [], "pred": []}), "records"),
        (lambda: compute_map([{"gt": []}]), r"records\[0\]"),
        (lambda: compute_map([{"gt": [], "pred": [cube_gt((0, 0, 1))]}]), r"records\[0\]\['pred'\]\[0\].*score"),
        (lambda: compute_map([{"gt": [{**cube_gt((0, 0, 1)), "size_m": [1, 1]}], "pred": []}]), "size_m"),
        (lambda: compute_map([], iou_thresholds=[1.5]), "iou_thresholds"),
        (lambda: compute_map([], pose_iou_gate=0.0), "pose_iou_gate"),
        (lambda: compute_map([], protocol="NOCS"), "protocol"),
        (lambda: tie_range([1, 0], [0.5], 1), "scores"),
        (lambda: nocs_average_precision([1], [np.nan], 1), "scores"),
    ],
)
def test_bad_inputs_raise_input_error(call, match):
    with pytest.raises(InputError, match=match):
        call()
