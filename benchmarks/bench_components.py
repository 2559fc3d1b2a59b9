"""Speed of the data-making components that tests must not time: instance builds and input corruptions.

    python benchmarks/bench_components.py [--seeds 20] [--out benchmarks/results_components.json]

* Instance builds: every category's ``SPEC.build`` for ``--seeds`` seeds of every shape family; reported per
  category: mean and max milliseconds and the mean face count. Target: mean < 100 ms per instance.
* Corruptions (:mod:`ucope.data.corrupt`): every kind at its strongest level on a 4096-point cloud with a
  3000-point background pool; best of 3 after a warm-up. Target: < 20 ms per call.

Exit status 1 when a target is missed (the figures are still written). Wall-clock figures depend on the
machine (they differ about 2x between ours): compare within one run.
"""

from __future__ import annotations

import argparse
import platform
import sys
import time
from pathlib import Path

import numpy as np
import torch

from ucope.data.corrupt import KINDS, BackgroundPool, CorruptionContext, corrupt
from ucope.fileio import atomic_write_json
from ucope.geometry.transforms import make_transform, random_rotation
from ucope.objects.categories import CATEGORY_NAMES, get_category
from ucope.render.noise import DepthNoise

BUILD_TARGET_S = 0.1
CORRUPT_TARGET_S = 0.02


def bench_builds(seeds: int) -> dict:
    out = {}
    for name in CATEGORY_NAMES:
        spec = get_category(name)
        times, faces = [], []
        for family in spec.family_names:
            for seed in range(seeds):
                t = time.perf_counter()
                obj = spec.build(np.random.default_rng(seed), f"{name}/{family}/{seed}", family)
                times.append(time.perf_counter() - t)
                faces.append(sum(len(p.mesh.faces) for p in obj.parts))
        t = np.array(times)
        out[name] = {"mean_ms": 1e3 * t.mean(), "max_ms": 1e3 * t.max(), "faces_mean": float(np.mean(faces)), "n": len(t)}
        print(f"build {name:13s} mean {out[name]['mean_ms']:6.2f} ms, max {out[name]['max_ms']:6.2f} ms", flush=True)
    return out


def bench_corruptions() -> dict:
    rng = np.random.default_rng(0)
    pts = (rng.normal(size=(4096, 3)) * 0.05 + [0, 0, 0.8]).astype(np.float32)
    lab = np.zeros(4096, np.int64)
    T0 = make_transform(random_rotation(rng), [0.0, 0.0, 0.8])
    pool = BackgroundPool(rng.normal(size=(3000, 3)) * 0.1 + [0.0, 0.1, 0.9], rng.integers(1, 40, 3000), rng.random(3000) < 0.3)
    ctx = CorruptionContext(T0[None], np.array([[0.2, 0.1, 0.15]]), pool, DepthNoise())
    out = {}
    for kind in KINDS.values():
        spec = f"{kind.name}={kind.levels[-1]:g}"
        corrupt(pts, lab, spec, np.random.default_rng(0), ctx)  # warm-up
        best = np.inf
        for _ in range(3):
            t = time.perf_counter()
            corrupt(pts, lab, spec, np.random.default_rng(0), ctx)
            best = min(best, time.perf_counter() - t)
        out[spec] = {"best_ms": 1e3 * best}
        print(f"corrupt {spec:16s} {1e3 * best:6.2f} ms", flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="seeds per shape family")
    ap.add_argument("--out", type=Path, default=Path(__file__).parent / "results_components.json")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    builds, corr = bench_builds(args.seeds), bench_corruptions()
    missed = [f"build {k}" for k, v in builds.items() if v["mean_ms"] > 1e3 * BUILD_TARGET_S]
    missed += [f"corrupt {k}" for k, v in corr.items() if v["best_ms"] > 1e3 * CORRUPT_TARGET_S]
    result = {
        "builds": builds,
        "corruptions": corr,
        "targets": {"build_mean_ms": 1e3 * BUILD_TARGET_S, "corrupt_ms": 1e3 * CORRUPT_TARGET_S},
        "missed": missed,
        "hardware": {"platform": platform.platform(), "processor": platform.processor(), "numpy": np.__version__},
    }
    atomic_write_json(args.out, result)
    print(f"wrote {args.out}; targets missed: {', '.join(missed) or 'none'}")
    return 1 if missed else 0


if __name__ == "__main__":
    sys.exit(main())
