"""Every command and Python snippet of README.md runs as written (so the README cannot rot).

The code blocks are run in README order in a scratch folder holding a copy of the repository's
``examples/`` (the inputs the README's commands use). Commands that would take minutes get size
overrides appended (argparse keeps the last value): ``generate --num``, ``train --steps``, ``eval
--num``; everything else runs exactly as printed. ``make`` lines are the set-up itself (CI runs
``make test``; ``make demo`` is covered by tests/cli/test_demo.py).
"""

from __future__ import annotations

import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from ucope.cli.main import main
from ucope.model.checkpoint import list_pretrained

README = Path(__file__).resolve().parent.parent / "README.md"

OVERRIDES = {
    "generate": lambda argv: ["--num", "16"] if int(argv[argv.index("--num") + 1]) > 16 else [],
    "train": lambda argv: ["--steps", "2", "--val-samples", "2", "--log-every", "1", "--quiet"],
    "eval": lambda argv: ["--num", "2", "--quiet"],
}


def readme_blocks() -> list[tuple[str, str]]:
    """``(language, code)`` of every fenced block of the README, in order."""
    return [(m.group(1), m.group(2)) for m in re.finditer(r"```(bash|python)\n(.*?)```", README.read_text(), re.S)]


def commands(code: str) -> list[str]:
    """The command lines of a bash block (comments stripped)."""
    out = []
    for line in code.splitlines():
        line = re.sub(r"\s+#.*$", "", line).strip()
        if line and not line.startswith("#"):
            out.append(line)
    return out


def test_the_readme_has_the_documented_sections():
    text = README.read_text()
    for heading in ("## Set-up, demo and tests", "## Predict", "## The pipeline", "## Models", "## Train", "## Your own objects"):
        assert heading in text
    assert "make demo" in text and "make test" in text
    assert len(README.read_bytes()) <= 10_000


@pytest.mark.skipif(not {"laptop", "mug"} <= set(list_pretrained()), reason="needs the shipped laptop and mug models")
def test_every_readme_command_runs(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    shutil.copytree(README.parent / "examples", tmp_path / "examples")  # the inputs the README uses, as a clone has them

    ran = []
    for lang, code in readme_blocks():
        if lang == "python":
            exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
            ran.append("python block")
            continue
        for line in commands(code):
            argv = shlex.split(line)
            if argv[0] == "make" or argv[0] == "pip":
                continue
            if argv[:3] == ["python", "-m", "ucope"]:
                r = subprocess.run([sys.executable, "-m", "ucope", *argv[3:]], capture_output=True, text=True, timeout=120)
                assert r.returncode == 0, r.stderr
            else:
                assert argv[0] == "ucope", line
                argv = argv[1:]
                argv += OVERRIDES.get(argv[0], lambda a: [])(argv)
                rc = main(argv)
                assert rc == 0, (line, capsys.readouterr().err)
            ran.append(line)
    text = capsys.readouterr().out
    assert len(ran) >= 13, ran
    assert Path("result.json").is_file() and Path("result.png").is_file()
    assert sorted(p.name for p in Path("results").iterdir()) == ["laptop_0.json", "laptop_1.json"]
    assert Path("frame.json").is_file() and Path("frame.csv").is_file() and Path("reports/laptop_val.json").is_file()
    assert "rotation" in text and "free_space" in text  # eval prints the errors, pipeline the stages
