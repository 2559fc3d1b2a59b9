import subprocess
import sys

import pytest

from ucope import __version__
from ucope.cli.main import main
from ucope.objects.categories import CATEGORY_NAMES


def test_version_and_help(capsys):
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0
    assert __version__ in capsys.readouterr().out
    assert main([]) == 0
    assert "generate" in capsys.readouterr().out


def test_python_dash_m():
    r = subprocess.run([sys.executable, "-m", "ucope", "--version"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0 and __version__ in r.stdout


def test_categories_lists_all_eleven(capsys):
    assert main(["categories"]) == 0
    out = capsys.readouterr().out
    for name in CATEGORY_NAMES:
        assert f"\n{name} " in out
    assert "revolute,revolute" in out and "prismatic,prismatic,prismatic" in out


def test_generate_and_show(tmp_path, capsys):
    out = tmp_path / "d"
    assert (
        main(
            [
                "generate",
                "--category",
                "eyeglasses",
                "--split",
                "test",
                "--num",
                "3",
                "--shard-size",
                "2",
                "--out",
                str(out),
                "--quiet",
            ]
        )
        == 0
    )
    assert (out / "shard_00001.npz").exists()
    png = tmp_path / "x.png"
    assert main(["show", str(out), "--index", "0", "2", "--out", str(png)]) == 0
    assert png.stat().st_size > 10_000


@pytest.mark.parametrize(
    "argv, message",
    [
        (
            ["generate", "--category", "teapot", "--num", "2", "--out", "{tmp}/a"],
            "unknown category 'teapot'; valid categories: laptop",
        ),
        (["generate", "--category", "mug", "--num", "0", "--out", "{tmp}/a"], "num must be a positive integer"),
        (["generate", "--category", "mug", "--num", "2", "--out", "{tmp}/file/sub"], "cannot write to output folder"),
        (["generate", "--category", "mug", "--num", "2", "--shards", "x", "--out", "{tmp}/a"], "--shards must look like"),
        (["show", "{tmp}/missing", "--out", "{tmp}/p.png"], "does not exist"),
    ],
)
def test_clear_errors_without_traceback(tmp_path, capsys, argv, message):
    (tmp_path / "file").write_text("x")
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_predict_with_the_up_direction(tmp_path, capsys):
    """``ucope predict --up``: a rolled camera's cloud is turned to image up (a warning says by how much);
    an up along the optical axis is refused with a clear error (the cloud fails alone: exit 2)."""
    import json

    import numpy as np

    from ucope.data.generate import GenerateConfig, make_sample

    s = make_sample(GenerateConfig(category="mug", split="test", num=1, views_per_instance=1), 0)
    np.save(tmp_path / "cloud.npy", s["points"])
    out = tmp_path / "r.json"
    base = ["predict", "--model", "mug", "--input", str(tmp_path / "cloud.npy"), "--pairs", "2000", "--quiet", "--out", str(out)]
    assert main([*base, "--up", "1", "0", "0"]) == 0
    warnings = json.loads(out.read_text())["warnings"]
    assert any("turned -90 degrees about the optical axis" in w for w in warnings)
    assert main([*base, "--up", "0", "0", "1"]) == 2
    err = capsys.readouterr().err
    assert "within 10 degrees of the optical axis" in err and "Traceback" not in err
