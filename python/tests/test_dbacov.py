"""`import dbacov` (build/python) against the command-line tool and on DROID-shaped tensors.

Run by ctest (python_dbacov) with /usr/bin/python3 and PYTHONPATH=build/python:share/droid.
Python and dba-covariance must agree to 1e-12 on the shared DROID snapshot and on its stereo and
RGB-D versions; the torch tests skip only when torch is genuinely missing.
"""

import os
import threading

import numpy as np
import pytest

import dbacov
import dbacov_dump
from conftest import (FakeGraph, FakeVideo, cli_marginals, rgbd_arrays, run_cli,
                      stereo_arrays)


def npz_arrays(path):
    with np.load(path) as z:
        return {k: z[k] for k in z.files}


def assert_agree(cov, cli, tol=1e-12):
    assert sorted(cli) == cov.keyframes
    for k, m in cli.items():
        scale = max(np.abs(m).max(), 1e-300)
        assert np.abs(cov.marginal(k) - m).max() <= tol * scale, k


def test_load_agrees_with_cli_on_the_shared_snapshot(shared_path, tmp_path):
    cov = dbacov.Covariance(dbacov.load(shared_path), preset="droid")
    assert_agree(cov, cli_marginals(shared_path, tmp_path))
    # every dba-covariance option as a keyword
    for kw, args in [({"preset": "paper"}, ["--preset", "paper"]),
                     ({"gauge": "minimal", "weight_scale": 0.01},
                      ["--gauge", "minimal", "--weight-scale", "0.01"]),
                     ({"gauge_sigma_rot": 0.01, "gauge_sigma_trans": 0.02, "near": 0.3,
                       "far": 3.0, "min_depth_ratio": 0.0, "solver": "dense", "threads": 1},
                      ["--gauge-sigma-rot", "0.01", "--gauge-sigma-trans", "0.02", "--near",
                       "0.3", "--far", "3", "--min-depth-ratio", "0", "--solver", "dense",
                       "--threads", "1"])]:
        cov = dbacov.Covariance(shared_path, **kw)
        assert_agree(cov, cli_marginals(shared_path, tmp_path, *args))


def test_results_shapes_and_relations(shared_path):
    cov = dbacov.Covariance(dbacov.load(shared_path))
    k = cov.keyframes
    assert k == list(range(1, 11))  # keyframe 0 takes part in no edge
    m = cov.marginals()
    assert m.shape == (10, 6, 6) and m.dtype == np.float64
    np.testing.assert_array_equal(m[3], cov.marginal(k[3]))
    j = cov.joint(4, 7)
    assert j.shape == (12, 12)
    np.testing.assert_allclose(j[:6, :6], cov.marginal(4), rtol=0, atol=1e-15)
    np.testing.assert_allclose(j[6:, 6:], cov.marginal(7), rtol=0, atol=1e-15)
    assert cov.relative(4, 7).shape == (6, 6)
    s = cov.inverse_depth_sigma(3)
    assert s.shape == (49, 61) and s.dtype == np.float32
    assert np.isfinite(s).mean() > 0.5
    assert cov.stats["factors_used"] > 0
    with pytest.raises(KeyError, match="keyframe 0 is not a graph keyframe"):
        cov.marginal(0)


def test_snapshot_from_numpy_arrays_is_the_loaded_one(shared_path):
    a = npz_arrays(shared_path)
    snap = dbacov.Snapshot(**{k: v for k, v in a.items()})
    np.testing.assert_array_equal(dbacov.Covariance(snap).marginals(),
                                  dbacov.Covariance(dbacov.load(shared_path)).marginals())
    # arrays of the snapshot dtypes, C-contiguous, are taken in place (no conversion)
    assert dbacov._array(a["disps"], np.float32) is a["disps"]
    assert dbacov._array(a["ii"], np.int64) is a["ii"]


def test_errors_are_python_exceptions_with_the_cli_messages(shared_path, tmp_path):
    missing = str(tmp_path / "broken.npz")
    with open(missing, "wb") as f:
        f.write(b"not a zip archive")
    with pytest.raises(dbacov.InputError) as e:
        dbacov.load(missing)
    assert isinstance(e.value, ValueError)
    r = run_cli("-i", missing, "--csv", str(tmp_path / "x.csv"))
    assert r.returncode in (1, 2)
    assert str(e.value) in r.stderr
    a = npz_arrays(shared_path)
    a["jj"] = a["jj"].copy()
    a["jj"][5] = a["ii"][5]
    with pytest.raises(dbacov.InputError, match="edge 5 links keyframe .* to itself.*stereo_rig"):
        dbacov.Snapshot(**a)
    a = npz_arrays(shared_path)
    with pytest.raises(dbacov.InputError, match=r"key 'target' has shape \(58,2,49\)"):
        dbacov.Snapshot(**dict(a, target=a["target"][:, :, :, 0]))
    with pytest.raises(ValueError, match="unknown gauge 'bogus'"):
        dbacov.Covariance(shared_path, gauge="bogus")
    with pytest.raises(dbacov.InputError, match="gauge droid needs DROID's t0"):
        dbacov.Covariance(shared_path, gauge="droid")
    # a snapshot whose reduced system is singular: monocular, DROID's gauge holding one pose
    # (named as dba-covariance names it, once)
    with pytest.raises(dbacov.NumericalError) as err:
        dbacov.Covariance(dbacov.Snapshot(**a, t0=2), gauge="droid")
    snap = dbacov.Snapshot(**a, t0=2)
    name = f"{snap.source} (snapshot "
    assert str(err.value).startswith(name), str(err.value)
    assert str(err.value).count(snap.source) == 1, str(err.value)
    assert "not positive definite" in str(err.value)


def test_a_bad_kernel_variant_in_the_environment_is_a_value_error(shared_path):
    # DBACOV_KERNEL_ISA is read once per process (docs/development/performance.md): a fresh interpreter.
    import subprocess
    import sys
    code = ("import dbacov, sys\n"
            "try:\n"
            "    dbacov.Covariance(sys.argv[1])\n"
            "except ValueError as e:\n"
            "    print('ValueError:', e)\n")
    for isa, expected in (("avx9", "ValueError: DBACOV_KERNEL_ISA=avx9: unknown pixel kernel"),
                          ("baseline", "")):
        r = subprocess.run([sys.executable, "-c", code, shared_path], capture_output=True,
                           text=True, env=dict(os.environ, DBACOV_KERNEL_ISA=isa), check=True)
        assert r.stdout.startswith(expected) and (expected or not r.stdout), r.stdout + r.stderr


def test_gil_is_released_during_the_computation(shared_path):
    snap = dbacov.load(shared_path)
    results = [None] * 4

    def work(i):
        results[i] = dbacov.Covariance(snap).marginals()

    threads = [threading.Thread(target=work, args=(i,)) for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for r in results[1:]:
        np.testing.assert_array_equal(r, results[0])


# --- DROID-shaped torch tensors: mono, stereo, RGB-D ---------------------------------------------

@pytest.fixture
def torch():
    return pytest.importorskip("torch", reason="python3-torch is not installed "
                                               "(scripts/setup.sh installs it)")


@pytest.mark.parametrize("mode", ["mono", "stereo", "rgbd"])
def test_from_droid_agrees_with_the_hook_and_the_cli(torch, shared_path, tmp_path, mode):
    a = npz_arrays(shared_path)
    a = {"mono": a, "stereo": stereo_arrays(a), "rgbd": rgbd_arrays(a)}[mode]
    video, graph = FakeVideo(torch, a), FakeGraph(torch, a)
    snap = dbacov.from_droid(video, graph, snapshot_id=55)
    assert snap.is_stereo == (mode == "stereo") and snap.is_rgbd == (mode == "rgbd")
    assert snap.t0 == int(a["ii"].min()) + 1
    path = tmp_path / "hook.npz"
    dbacov_dump.dump_dba_snapshot(str(path), video, graph, 55, include_inactive=True)
    opts = {"gauge": "droid"} if mode != "mono" else {}
    args = ["--gauge", "droid"] if mode != "mono" else []
    cov = dbacov.Covariance(snap, **opts)
    assert_agree(cov, cli_marginals(path, tmp_path, *args))
    if mode == "mono":  # the hook on DROID's tensors reproduces the shared snapshot's numbers
        assert_agree(cov, cli_marginals(shared_path, tmp_path))


def test_stereo_and_rgbd_add_information(torch, shared_path):
    a = npz_arrays(shared_path)
    mono = dbacov.Covariance(dbacov.Snapshot(**a))
    for extra in (stereo_arrays(a), rgbd_arrays(a)):
        cov = dbacov.Covariance(dbacov.Snapshot(**extra))
        for k in cov.keyframes:
            if cov.free_dof(k):
                assert np.trace(cov.marginal(k)) < np.trace(mono.marginal(k)), k


def test_from_droid_keeps_true_keyframe_times_across_a_stale_removal(torch, shared_path):
    # DROID before 2025: rm_keyframe does not shift tstamp; the record corrects it.
    a = npz_arrays(shared_path)
    video, graph = FakeVideo(torch, a), FakeGraph(torch, a)
    record = dbacov.KeyframeRecord()
    first = dbacov.from_droid(video, graph, record=record)
    np.testing.assert_array_equal(first.tstamp, a["tstamp"])
    n = video.counter.value
    video.tstamp[n] = 60  # frame 60 appended, then the second newest (frame 55) removed
    for name in ("poses", "disps", "images", "intrinsics", "disps_sens"):
        buf = getattr(video, name)
        buf[n] = buf[n - 1] if name != "images" else buf[n] // 2 + 1
        buf[n - 1:n] = buf[n:n + 1].clone()
    snap = dbacov.from_droid(video, FakeGraph(torch, a), record=record,
                             image_times_s=np.arange(100) * 0.05)
    np.testing.assert_array_equal(snap.tstamp, list(a["tstamp"][:-1]) + [60])
    np.testing.assert_allclose(snap.timestamps_s, snap.tstamp * 0.05)
