#!/usr/bin/env python3
"""A robot driver loop in Python (docs/python.md): the virtual scanner stands in for the robot.

A real driver replaces `robot.scan(view)` with moving the arm to `view` (a dict with position,
direction, up), triggering the scanner, and passing its points (world frame of the pose the robot
reports) to `session.add_scan`. Everything else stays as it is.

    python3 examples/python/robot_driver.py data/models/bunny00.off /tmp/driver [--max-views 30]
"""

import argparse
import logging

import numpy as np

import autoscan


class VirtualRobot:
    """The scanner on a robot: takes a view, returns the points and the pose it reports."""

    def __init__(self, mesh, scanner):
        self.scanner = autoscan.VirtualScanner(mesh, scanner=scanner)
        self.scans = 0

    def scan(self, view):
        r = self.scanner.scan(view, scan_id=self.scans)
        self.scans += 1
        return r.cloud, r.commanded


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("mesh", help="the object (any mesh file autoscan reads)")
    ap.add_argument("out", help="session directory (created)")
    ap.add_argument("--max-views", type=int, default=30)
    ap.add_argument("--max-iterations", type=int, default=6)
    ap.add_argument("--fast", action="store_true", help="small settings (the test suite uses them)")
    args = ap.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")

    mesh = autoscan.read_mesh(args.mesh)
    lo, hi = mesh.bounds()  # the benchmark frame: centred, bounding-box diagonal 1
    mesh.vertices[:] = (mesh.vertices - 0.5 * (lo + hi)) / np.linalg.norm(hi - lo)
    scanner = {"width": 160, "height": 120} if args.fast else {}
    # The virtual scanner is exact (no noise): no denoising needed (a real scanner: leave it out).
    options = {"max_views": args.max_views, "max_iterations": args.max_iterations,
               "consolidate": {"wlop": {"noise_hint": 0}}}
    if args.fast:
        options |= {"poisson": {"depth": 6}, "confidence": {"iso": {"count": 1500}, "k": 30},
                    "nbv": {"grid_resolution": 32, "cells": 4, "max_views": 3}, "global_registration": False}
    robot = VirtualRobot(mesh, scanner)

    with autoscan.Session.create(args.out, scanner=scanner, rig="free", options=options) as session:
        for view in robot.scanner.blind_scan({"views": 8}).poses:  # the initial all-round scan
            session.add_scan(*robot.scan(view))
        while not (step := session.next_views()).stopped:
            print(f"iteration {step.iteration}: mean confidence {step.mean_f:.3f}, {len(step.views)} views")
            for view in step.views:
                session.add_scan(*robot.scan(view))
        status = session.status()
    print(f"stopped ({status['stop_reason']}) after {status['iterations']} iterations, "
          f"{status['scans']} scans, mean confidence {status['last_mean_f']:.3f}")


if __name__ == "__main__":
    main()
