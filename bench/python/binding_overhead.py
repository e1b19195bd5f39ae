#!/usr/bin/env python3
"""Overhead of the Python binding (docs/benchmarks.md, "Python binding"): the same reconstruct and
plan from Python, from the CLI and from C++, in one run, as ratios to the C++ call.

    PYTHONPATH=build/python python3 bench/python/binding_overhead.py --build build [--model bunny00] [--repeats 3]

The input is a consolidated blind scan of the model (normalised), written once as PLY; the CLI
times include starting the process and reading and writing the files, as a user of the CLI pays.
"""

import argparse
import json
import pathlib
import statistics
import subprocess
import tempfile
import time

import numpy as np

import autoscan


def median_time(repeats, f):
    t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        f()
        t.append(time.perf_counter() - t0)
    return statistics.median(t)


def main():
    root = pathlib.Path(__file__).resolve().parents[2]
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default=root / "build", type=pathlib.Path)
    ap.add_argument("--model", default="bunny00")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    args.build = args.build.resolve()

    mesh = autoscan.read_mesh(root / "data" / "models" / f"{args.model}.off")
    lo, hi = mesh.bounds()
    mesh.vertices[:] = (mesh.vertices - 0.5 * (lo + hi)) / np.linalg.norm(hi - lo)
    raw = autoscan.blind_scan(mesh).cloud
    # The virtual scanner is exact: no denoising; thinned to a session's per-iteration size.
    cloud = autoscan.consolidate(raw, {"wlop": {"noise_hint": 0}, "thinning": {"max_points": 100000}}).cloud
    print(f"{args.model}: {len(raw)} scanned, {len(cloud)} consolidated points", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(tmp)
        path = tmp / "cloud.ply"
        autoscan.write_point_cloud(path, cloud, double_coordinates=True)
        cloud = autoscan.read_point_cloud(path)  # the same bits as the CLI and C++ read
        # Zero copy: the arrays are views of the C++ cloud.
        assert cloud.positions.base is cloud
        assert cloud.positions.__array_interface__["data"][0] == cloud.positions.__array_interface__["data"][0]

        def py_plan():
            a = autoscan.assess_cloud(cloud)
            return autoscan.plan(a.reconstruction.mesh, a.confidence.iso_points, field=a.reconstruction.field)

        cpp = json.loads(subprocess.run([args.build / "bench" / "binding_overhead", path, str(args.repeats)],
                                        check=True, capture_output=True, text=True).stdout)
        print("C++:", cpp, flush=True)
        py = {"reconstruct": median_time(args.repeats, lambda: autoscan.reconstruct(cloud)),
              "plan": median_time(args.repeats, py_plan)}
        print("Python:", py, flush=True)
        cli_exe = args.build / "autoscan"
        cli = {
            "reconstruct": median_time(args.repeats, lambda: subprocess.run(
                [cli_exe, "-q", "reconstruct", "--cloud", path, "--out", tmp / "mesh.ply"], check=True)),
            "plan": median_time(args.repeats, lambda: subprocess.run(
                [cli_exe, "-q", "plan", "--cloud", path, "--out", tmp / "views.json"], check=True,
                stdout=subprocess.DEVNULL)),
        }
    print(f"median of {args.repeats} runs")
    print("| call | C++ (s) | Python (s) | CLI (s) | Python / C++ | CLI / C++ |")
    print("| --- | --- | --- | --- | --- | --- |")
    for k in ("reconstruct", "plan"):
        print(f"| {k} | {cpp[k]:.3f} | {py[k]:.3f} | {cli[k]:.3f} | {py[k] / cpp[k]:.3f} | {cli[k] / cpp[k]:.3f} |")


if __name__ == "__main__":
    main()
