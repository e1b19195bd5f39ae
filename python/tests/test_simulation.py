import logging

import autoscan
from conftest import SESSION, SCANNER


def test_simulate_and_evaluate(tmp_path, eight_path, recon, eight):
    opts = {
        "session": dict(SESSION, max_iterations=2),
        "scanner": SCANNER,
        "blind": {"views": 6},
        "eval": {"samples": 5000},
        "scannable": False,
        "report": False,
    }
    r = autoscan.simulate(eight_path, tmp_path / "sim", opts)
    assert r["iterations"] == 2 and r["scans"] >= 6 and 0 <= r["mean_f"] <= 1
    assert 0 <= r["truth"]["fscore"] <= 1
    assert (tmp_path / "sim" / "session.json").exists()
    e = autoscan.evaluate(recon.mesh, eight, {"samples": 5000})
    assert e["accuracy"]["mean"] < 0.01 and 0.5 < e["fscore"] <= 1
    c = autoscan.evaluate_cloud(autoscan.PointCloud(recon.mesh.vertices), eight, {"samples": 5000})
    assert 0.5 < c["coverage"] <= 1


def test_logging_reaches_python(caplog, consolidated):
    with caplog.at_level(logging.DEBUG, logger="autoscan"):
        autoscan.reconstruct(consolidated, {"depth": 5})
    records = [r for r in caplog.records if r.name == "autoscan"]
    assert any("%" in r.getMessage() for r in records)  # stage progress at DEBUG level


def test_robot_driver_example(tmp_path, eight_path):
    import os
    import subprocess
    import sys

    from conftest import SOURCE

    out = subprocess.run(
        [sys.executable, SOURCE / "examples" / "python" / "robot_driver.py", eight_path, tmp_path / "drv",
         "--fast", "--max-iterations", "3"],
        check=True, capture_output=True, text=True, env=dict(os.environ)).stdout
    # The stop rule (docs/stop-rule.md) or the budget of 3 iterations ends it.
    import re
    m = re.search(r"stopped \((\w+)\) after (\d+) iterations", out)
    assert m and 1 <= int(m.group(2)) <= 3, out
