import numpy as np
import pytest

import autoscan
from conftest import SESSION, SCANNER


def test_three_iteration_session_driven_from_python(tmp_path, scanner, blind):
    d = tmp_path / "s"
    with autoscan.Session.create(d, scanner=SCANNER, rig="free", options=SESSION) as s:
        for i in range(len(blind.poses)):  # the blind scan, one scan per pose
            r = scanner.scan(blind.poses[i], scan_id=i)
            rec = s.add_scan(r.cloud, r.commanded)
            assert rec["id"] == i and rec["points"] == len(r.cloud)
        scan_id = len(blind.poses)
        steps = []
        while True:
            step = s.next_views()
            steps.append(step)
            if step.stopped:
                break
            assert step.views and step.mesh is not None and 0 <= step.mean_f <= 1
            for view in step.views:
                r = scanner.scan(view, scan_id=scan_id)
                scan_id += 1
                s.add_scan(r.cloud, r.commanded)
        assert [x.iteration for x in steps] == [0, 1, 2]
        assert steps[-1].reason == "max_iterations"
        status = s.status()
        assert status["iterations"] == 3 and status["stopped"] and status["scans"] == scan_id
        assert len(s.iterations()) == 3 and len(s.model_points()) == status["model_points"]
        assert s.options["poisson"]["depth"] == 6
        # One process per directory: the lock is held while the session is open.
        with pytest.raises(autoscan.Error):
            autoscan.Session.open(d)
    # Closed: it can be resumed, and the stopped answer is replayed.
    with autoscan.Session.open(d) as s:
        assert s.status()["scans"] == scan_id
        again = s.next_views()
        assert again.stopped and again.mesh is None
    with pytest.raises(autoscan.Error, match="closed"):
        s.status()


def test_session_errors(tmp_path):
    with pytest.raises(autoscan.InputError, match="unknown option 'max_veiws'"):
        autoscan.Session.create(tmp_path / "x", options={"max_veiws": 3})
    with pytest.raises(autoscan.InputError):
        autoscan.Session.open(tmp_path / "nothing")
    with autoscan.Session.create(tmp_path / "y") as s:
        with pytest.raises(autoscan.InputError):
            s.next_views()
        with pytest.raises(autoscan.InputError, match="position"):
            s.add_scan(autoscan.PointCloud(np.zeros((1, 3))), {"direction": [1, 0, 0]})
