"""share/droid/dbacov_online.py: each new keyframe's sigma while DROID's frontend runs.

Run by ctest (python_droid_online) with PYTHONPATH=build/python:share/droid. Simulator snapshots
(simul-dba's sliding window: one new keyframe per snapshot, as DROID's frontend adds them) are fed
through fake DepthVideo/FactorGraph objects holding DROID-shaped torch tensors; the printed sigma
must equal sqrt(diag) of `dba-covariance --csv` on what the dump hook writes from the same
objects (1e-9), and no failure inside may reach the frontend.
"""

import io
import os
import subprocess
import sys

import numpy as np
import pytest

import dbacov
import dbacov_dump
import dbacov_online
from conftest import FakeGraph, FakeVideo, run_cli

SIMUL = os.environ.get("DBACOV_SIMUL", "")
ONLINE = dbacov_online.__file__
TESTS = os.path.dirname(os.path.abspath(__file__))


@pytest.fixture
def torch():
    return pytest.importorskip("torch", reason="python3-torch is not installed "
                                               "(scripts/setup.sh installs it)")


@pytest.fixture
def sim_files(tmp_path):
    if not os.path.exists(SIMUL):
        pytest.fail(f"simul-dba not found: {SIMUL!r} (DBACOV_SIMUL)")
    out = tmp_path / "sim"
    r = subprocess.run([SIMUL, "-o", str(out), "--snapshots", "5", "--seed", "1", "--height",
                        "24", "--width", "32", "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return sorted(out.glob("snapshot_*.npz"))


def npz_arrays(path):
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def parse(line):
    """(keyframe, frame, sigma_t (3,), sigma_r_deg (3,)) of one printed line."""
    w = line.split()
    assert w[0] == "dbacov:" and w[1] == "keyframe" and w[3] == "frame", line
    t = w.index("sigma_t")
    r = w.index("sigma_r_deg")
    return (int(w[2]), float(w[4]), np.array(w[t + 1:t + 4], float),
            np.array(w[r + 1:r + 4], float))


def cli_sigmas(dump_dir, tmp_path, *options):
    """{snapshot id: (newest keyframe, sigma_t, sigma_r_deg)} from dba-covariance --csv."""
    out = tmp_path / "k.csv"
    r = run_cli("-i", str(dump_dir), "--csv", str(out), "-q", *options)
    assert r.returncode == 0, r.stderr
    lines = out.read_text().splitlines()
    head = lines[0].split(",")
    first = head.index("cov_00")
    newest = {}
    for line in lines[1:]:
        v = line.split(",")
        s, k = int(v[0]), int(v[1])
        if s not in newest or k > newest[s][0]:
            m = np.zeros((6, 6))
            m[np.triu_indices(6)] = [float(x) for x in v[first:first + 21]]
            d = np.diag(m)
            newest[s] = (k, np.sqrt(d[:3]), np.degrees(np.sqrt(d[3:])))
    return newest


def frontend_objects(torch, path):
    a = npz_arrays(path)
    return FakeVideo(torch, a, capacity=32), FakeGraph(torch, a)


def test_prints_each_new_keyframes_sigma_as_the_cli(torch, sim_files, tmp_path):
    out = io.StringIO()
    printer = dbacov_online.KeyframeSigmaPrinter(out=out, weight_scale=4,
                                                 image_times_s=np.arange(1000) * 0.05)
    dumps = tmp_path / "dumps"
    dumps.mkdir()
    for s, f in enumerate(sim_files):
        video, graph = frontend_objects(torch, f)
        assert printer(video, graph, s) is not None
        assert printer(video, graph, s) is None  # the same keyframe again: no new line
        dbacov_dump.dump_dba_snapshot(str(dumps / f"window_{s:06d}.npz"), video, graph, s,
                                      include_inactive=True)
    assert printer.failures == 0 and printer.printed == len(sim_files)
    lines = out.getvalue().splitlines()
    assert len(lines) == len(sim_files)
    cli = cli_sigmas(dumps, tmp_path, "--weight-scale", "4")
    for s, line in enumerate(lines):
        k, frame, st, sr = parse(line)
        assert (k, frame) == (cli[s][0], 3.0 * k)  # simul-dba: tstamp = 3k
        assert f" t {3 * k * 0.05:.6f} s:" in line
        np.testing.assert_allclose(st, cli[s][1], rtol=1e-9, atol=0)
        np.testing.assert_allclose(sr, cli[s][2], rtol=1e-9, atol=0)
    assert k == 11  # 5 snapshots of the 8-keyframe window: keyframes 7..11 are new


def test_a_failure_inside_never_reaches_the_frontend(torch, sim_files, monkeypatch):
    out, err = io.StringIO(), io.StringIO()
    printer = dbacov_online.KeyframeSigmaPrinter(out=out, stream=err, weight_scale=4)
    video, graph = frontend_objects(torch, sim_files[0])
    broken = FakeGraph(torch, npz_arrays(sim_files[0]))
    broken.target = broken.target[..., :1]  # not (1,E,H,W,2)
    assert printer(video, broken, 0) is None
    assert printer(video, broken, 1) is None
    assert printer.failures == 2 and out.getvalue() == ""
    assert err.getvalue().count("dbacov_online: update 0: no sigma (ValueError") == 1
    assert err.getvalue().count("\n") == 1  # each kind reported once

    def boom(*args, **kwargs):
        raise dbacov.NumericalError("reduced system not positive definite")

    monkeypatch.setattr(dbacov, "Covariance", boom)
    assert printer(video, graph, 2) is None
    assert "NumericalError: reduced system" in err.getvalue()
    monkeypatch.undo()
    assert printer(video, graph, 3) is not None  # and it goes on
    assert printer.failures == 3 and printer.printed == 1


def test_install_wraps_current_and_old_frontends(torch, sim_files):
    video, graph = frontend_objects(torch, sim_files[0])

    class Current:  # DROID-SLAM 2025: DroidFrontend._update
        def __init__(self):
            self.video, self.graph, self.count, self.updates = video, graph, 7, 0

        def _update(self):
            self.updates += 1
            return "done"

    class Old:  # 2021/2022 releases: DroidFrontend.__update (name-mangled)
        def __init__(self):
            self.video, self.graph, self.count, self.updates = video, graph, 7, 0

        def __update(self):
            self.updates += 1

        def __call__(self):
            self.__update()

    calls = []
    dbacov_online.install(lambda v, g, c: calls.append((v, g, c)), Current)
    f = Current()
    assert f._update() == "done" and f.updates == 1 and calls == [(video, graph, 7)]

    def failing(v, g, c):
        raise RuntimeError("a hook bug")

    dbacov_online.install(failing, Old)
    o = Old()
    o()  # the hook's exception does not reach DROID
    assert o.updates == 1
    dbacov_online.install(lambda v, g, c: calls.append(c), Old)  # re-installed: replaced
    o()
    assert o.updates == 2 and calls[-1] == 7


DEMO = '''
import sys
import numpy as np
import torch
from conftest import FakeGraph, FakeVideo
from droid_frontend import DroidFrontend
frontend = None
for s, path in enumerate(sys.argv[1:]):
    with np.load(path) as z:
        a = {k: z[k] for k in z.files}
    video, graph = FakeVideo(torch, a, capacity=32), FakeGraph(torch, a)
    if frontend is None:
        frontend = DroidFrontend(video, graph)
    frontend.video, frontend.graph = video, graph
    frontend()
'''

FRONTEND = '''
class DroidFrontend:  # the shape of DROID-SLAM's droid_slam/droid_frontend.py (pre-2025)
    def __init__(self, video, graph):
        self.video, self.graph, self.count = video, graph, 0
    def __update(self):
        self.count += 1
    def __call__(self):
        self.__update()
'''


def test_command_line_runs_a_droid_script_with_the_hook(torch, sim_files, tmp_path):
    droid = tmp_path / "droid_slam"
    droid.mkdir()
    (droid / "droid_frontend.py").write_text(FRONTEND)
    (tmp_path / "demo.py").write_text(DEMO)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [os.environ.get("PYTHONPATH", ""), str(droid), TESTS]))
    r = subprocess.run([sys.executable, ONLINE, "--weight-scale", "4", "--fps", "20", "--",
                        str(tmp_path / "demo.py"), *map(str, sim_files)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(lines) == len(sim_files) and r.stderr == ""
    printer = dbacov_online.KeyframeSigmaPrinter(out=io.StringIO(), weight_scale=4,
                                                 image_times_s=np.arange(1000) / 20)
    for s, f in enumerate(sim_files):
        assert lines[s] == printer(*frontend_objects(torch, f), s + 1)
    assert " t 1.650000 s: " in lines[-1]  # keyframe 11, frame 33, at 20 fps
    # dba-covariance's noise-model options and --converge-iterations reach Covariance as its
    # keywords.
    r = subprocess.run([sys.executable, ONLINE, "--weight-scale", "4", "--self-calibrate-nodes",
                        "0", "--self-calibrate-depth-noise", "off", "--converge-iterations",
                        "3", "--", str(tmp_path / "demo.py"), *map(str, sim_files[:2])],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    printer = dbacov_online.KeyframeSigmaPrinter(out=io.StringIO(), weight_scale=4,
                                                 self_calibrate_nodes=0,
                                                 self_calibrate_depth_noise=False,
                                                 converge_iterations=3)
    plain = dbacov_online.KeyframeSigmaPrinter(out=io.StringIO(), weight_scale=4)
    for s, f in enumerate(sim_files[:2]):
        line = r.stdout.splitlines()[s]
        assert line == printer(*frontend_objects(torch, f), s + 1)
        assert line != plain(*frontend_objects(torch, f), s + 1)
    # --stated-model reaches Covariance as stated_model=True.
    r = subprocess.run([sys.executable, ONLINE, "--weight-scale", "4", "--stated-model", "--",
                        str(tmp_path / "demo.py"), *map(str, sim_files[:2])],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    stated = dbacov_online.KeyframeSigmaPrinter(out=io.StringIO(), weight_scale=4,
                                                stated_model=True)
    for s, f in enumerate(sim_files[:2]):
        line = r.stdout.splitlines()[s]
        assert line == stated(*frontend_objects(torch, f), s + 1)
        assert line != plain(*frontend_objects(torch, f), s + 1)
    r = subprocess.run([sys.executable, ONLINE], capture_output=True, text=True, env=env)
    assert r.returncode == 2 and "give DROID-SLAM's script after --" in r.stderr
    # Out-of-range numbers are refused before DROID runs, not per update after it.
    for option, value, message in (("--converge-iterations", "0", "1..100000"),
                                   ("--self-calibrate-nodes", "1", "0 (affine) or 2..8")):
        r = subprocess.run([sys.executable, ONLINE, option, value, "--", str(tmp_path / "demo.py"),
                            *map(str, sim_files[:1])], capture_output=True, text=True, env=env)
        assert r.returncode == 2 and r.stdout == "", r.stderr
        assert f"{option}: {value} is not in {message}" in r.stderr


RAN = '''
import pathlib, sys
pathlib.Path(sys.argv[1]).write_text("DROID ran")
'''


def test_bad_options_are_refused_before_droid_starts(tmp_path):
    script = tmp_path / "droid.py"
    script.write_text(RAN)
    marker = tmp_path / "ran"
    cases = [
        (["--gauge", "foo"], "--gauge foo: unknown gauge 'foo', expected two-pose, minimal or "
                             "droid"),
        (["--preset", "x"], "--preset x: unknown preset 'x', expected droid, paper or dpvo"),
        (["--weight-scale", "0"], "--weight-scale 0.0: weight scale must be finite and > 0"),
        (["--weight-scale", "-1"], "--weight-scale -1.0: weight scale must be finite and > 0"),
        (["--fps", "0"], "--fps 0: expected a finite positive frame rate (frames per second)"),
        (["--fps", "-20"], "--fps -20: expected a finite positive frame rate (frames per "
                           "second)"),
        (["--fps", "nan"], "--fps nan: expected a finite positive frame rate (frames per "
                           "second)"),
        (["--digits", "0"], "--digits: 0 is not in 1..17"),
    ]
    for args, message in cases:
        r = subprocess.run([sys.executable, ONLINE, *args, "--", str(script), str(marker)],
                           capture_output=True, text=True)
        assert r.returncode == 2 and r.stdout == "", (args, r.stderr)
        assert r.stderr.splitlines()[-1] == "dbacov_online.py: error: " + message, args
        assert not marker.exists(), args
    # and good options start it
    droid = tmp_path / "droid_slam"
    droid.mkdir()
    (droid / "droid_frontend.py").write_text(FRONTEND)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.environ.get("PYTHONPATH", ""),
                                                       str(droid)]))
    r = subprocess.run([sys.executable, ONLINE, "--fps", "20", "--gauge", "minimal", "--",
                        str(script), str(marker)], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert marker.read_text() == "DROID ran"


def test_printer_checks_its_keywords_when_made():
    with pytest.raises(ValueError, match="^unknown gauge 'foo', expected two-pose, minimal or "
                                         "droid$"):
        dbacov_online.KeyframeSigmaPrinter(gauge="foo")
    with pytest.raises(TypeError, match="^check_options\\(\\) got an unknown keyword argument "
                                        "'weightscale' \\(did you mean 'weight_scale'\\?\\)"):
        dbacov_online.KeyframeSigmaPrinter(weightscale=3)
