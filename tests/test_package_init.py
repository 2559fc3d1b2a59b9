"""``import ucope``: light, its public names reachable and listed (tab completion)."""

import subprocess
import sys


def test_dir_lists_the_lazy_names_and_importing_stays_light():
    code = (
        "import sys, ucope; d = dir(ucope); "
        "print('Estimator' in d, 'PoseResult' in d, 'data' in d, '__version__' in d, "
        "'ucope.estimation.estimator' in sys.modules, 'torch' in sys.modules); "
        "print(ucope.PoseResult.__name__, ucope.Estimator.__name__)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split("\n")
    assert out[0] == "True True True True False False"  # listed, yet nothing heavy imported
    assert out[1] == "PoseResult Estimator"  # and each resolves on first use
