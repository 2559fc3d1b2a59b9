import numpy as np
import pytest

from ucope.errors import DataError, InputError
from ucope.estimation.export import BOP_CSV_HEADER, BopRow, bop_rows, frame_bop_rows, read_bop_csv, write_bop_csv
from ucope.estimation.result import JointEstimate, PartEstimate, PoseResult
from ucope.geometry.transforms import random_rotation


def _result(rng, K=2, total_ms=40.0) -> PoseResult:
    parts = []
    for k in range(K):
        T = np.eye(4)
        T[:3, :3] = random_rotation(rng)
        T[:3, 3] = [0.1 * k, -0.05, 1.2]
        parts.append(PartEstimate(k, f"p{k}", T, np.array([0.3, 0.02, 0.2]), 0.9 - 0.1 * k))
    joints = [JointEstimate("revolute", 0, k, np.zeros(3), np.array([1.0, 0, 0]), 0.5) for k in range(1, K)]
    return PoseResult("x", parts, joints, np.zeros(5, np.int64), timings_ms={"total": total_ms})


def test_rows_map_part_k_to_base_plus_k_in_millimetres(rng, tmp_path):
    r = _result(rng)
    rows = bop_rows(r, scene_id=3, im_id=12, obj_id=5)
    assert [row.obj_id for row in rows] == [5, 6]
    np.testing.assert_allclose(rows[1].t_mm, [100.0, -50.0, 1200.0])
    assert rows[0].time_s == pytest.approx(0.04) and rows[0].score == pytest.approx(0.9)
    path = write_bop_csv(tmp_path / "sub" / "res.csv", rows)
    lines = path.read_text().splitlines()
    assert lines[0] == ",".join(BOP_CSV_HEADER)
    fields = lines[1].split(",")
    assert fields[:3] == ["3", "12", "5"] and len(fields[4].split()) == 9 and len(fields[5].split()) == 3
    back = read_bop_csv(path)
    np.testing.assert_allclose(back[0].R, r.parts[0].cam_from_part[:3, :3], atol=1e-6)  # row-wise
    np.testing.assert_allclose(back[1].t_mm, rows[1].t_mm, atol=1e-6)


def test_one_time_per_image_the_sum_of_its_objects(rng, tmp_path):
    a, b = _result(rng, 1, 30.0), _result(rng, 2, 45.0)
    rows = frame_bop_rows([(a, 1), (b, 2)], scene_id=0, im_id=4)
    assert [r.obj_id for r in rows] == [1, 2, 3] and [r.time_s for r in rows] == pytest.approx([0.075] * 3)
    with pytest.raises(InputError, match="one time per image"):
        write_bop_csv(tmp_path / "x.csv", bop_rows(a, 0, 4) + bop_rows(b, 0, 4))
    assert bop_rows(PoseResult("x", a.parts, [], np.zeros(1)), 0, 0)[0].time_s == -1.0


def test_bad_ids_and_files(rng, tmp_path):
    r = _result(rng)
    with pytest.raises(InputError, match="obj_id must be a positive integer"):
        bop_rows(r, 0, 0, obj_id=0)
    with pytest.raises(InputError, match="im_id must be a non-negative integer"):
        bop_rows(r, 0, -1)
    with pytest.raises(DataError, match="does not exist"):
        read_bop_csv(tmp_path / "none.csv")
    (tmp_path / "bad.csv").write_text("a,b\n")
    with pytest.raises(DataError, match="header"):
        read_bop_csv(tmp_path / "bad.csv")
    write_bop_csv(tmp_path / "ok.csv", [BopRow(0, 0, 1, 0.5, np.eye(3), np.zeros(3))])
    text = (tmp_path / "ok.csv").read_text().replace("0.000000 0.000000 0.000000,", "0 0,")
    (tmp_path / "short.csv").write_text(text)
    with pytest.raises(DataError, match=r"short\.csv, line 2: R needs 9 values and t 3"):
        read_bop_csv(tmp_path / "short.csv")
