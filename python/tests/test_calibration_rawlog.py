"""`import dbacov`: the noise-model keywords and the pose-rawlog writer, against dba-covariance.

Run by ctest (python_dbacov). Self-calibrated covariances (the default) must agree with
`dba-covariance` to 1e-12, the per-edge values with its --edge-csv (printed with 6 digits), and a
pose rawlog written from Python must hold the same bytes (after gunzip) as `dba-covariance -o`.
"""

import gzip
import os
import subprocess
import sys

import numpy as np
import pytest

import dbacov
from conftest import cli_marginals, run_cli
from test_dbacov import assert_agree

SIMUL = os.environ.get("DBACOV_SIMUL", "")


def edge_csv(path):
    lines = open(path).read().splitlines()
    head = lines[0].split(",")
    rows = [dict(zip(head, line.split(","))) for line in lines[1:]]
    return head, rows


@pytest.mark.parametrize("nodes", [None, 0, 3])
def test_self_calibration_agrees_with_the_cli(shared_path, tmp_path, nodes):
    kw = {}
    args = ["--edge-csv", str(tmp_path / "edges.csv")]
    if nodes is not None:
        kw["self_calibrate_nodes"] = nodes
        args += ["--self-calibrate-nodes", str(nodes)]
    cov = dbacov.Covariance(shared_path, **kw)
    assert_agree(cov, cli_marginals(shared_path, tmp_path, *args))
    cal = cov.self_calibration
    assert cal["method"] == "nuisance"
    g = 4 if nodes is None else nodes  # the default spline, or the one asked for
    assert cal["field_params"] == 2 * (3 + (g * g if g >= 2 else 0))
    assert cal["field_sigma"] + cal["field_fine_sigma"] > 0  # the snapshot has a field
    assert cal["passes"] >= 1 and cal["optimum"]["free_dof"] == 48
    assert not cal["optimum"]["unreliable"]
    _, rows = edge_csv(tmp_path / "edges.csv")
    edges = cal["edges"]
    assert len(rows) == len(edges["inflation"]) == cov.snapshot.num_edges == 58
    for key in ("i", "j", "pixels"):
        np.testing.assert_array_equal(edges[key], [int(r[key]) for r in rows])
    for key in ("residual_rms", "inflation", "effective_pixels", "redundancy", "vce_scale",
                "correlation"):
        np.testing.assert_allclose(edges[key], [float(r[key]) for r in rows], rtol=1e-5,
                                   atol=0, err_msg=key)
    assert {r["method"] for r in rows} == {cal["method"]}
    assert f"self-calibrated ({cal['method']})" in cov.summary()
    assert f"self-calibration         {cal['method']}" in cov.summary(full=True)


def test_stated_model_is_the_uncalibrated_engine(shared_path, tmp_path):
    cov = dbacov.Covariance(shared_path, stated_model=True)
    assert cov.self_calibration is None and cov.converged is None
    assert "self-calibrated" not in cov.summary()
    assert cov.summary().startswith("10 keyframes, 58 edges")
    raw = cli_marginals(shared_path, tmp_path, "--stated-model")
    assert_agree(cov, raw)
    cal = dbacov.Covariance(shared_path)
    k = cov.keyframes[-1]
    assert np.trace(cal.marginal(k)) < 1e-3 * np.trace(raw[k])  # ~170x smaller sigma (README, first run)


def test_converge_then_self_calibrate_agrees_with_the_cli(shared_path, tmp_path):
    snap = dbacov.load(shared_path)
    cov = dbacov.Covariance(snap, converge=True)
    assert cov.converged is True
    assert cov.snapshot is not snap  # solved on a copy: the caller's snapshot is kept
    np.testing.assert_array_equal(snap.poses, dbacov.load(shared_path).poses)
    assert_agree(cov, cli_marginals(shared_path, tmp_path, "--converge"))


def test_converge_iterations_keyword_caps_the_solve_as_the_cli(shared_path, tmp_path):
    # converge_iterations implies converge, as --converge-iterations does; the shared snapshot
    # needs 7 iterations, so a cap of 2 leaves it unconverged (the state as the solve left it).
    capped = dbacov.Covariance(shared_path, converge_iterations=2, stated_model=True)
    assert capped.converged is False
    assert_agree(capped, cli_marginals(shared_path, tmp_path, "--converge-iterations", "2",
                                       "--stated-model"))
    full = dbacov.Covariance(shared_path, converge=True, converge_iterations=50,
                             stated_model=True)
    assert full.converged is True
    k = full.keyframes[-1]
    assert np.abs(full.marginal(k) - capped.marginal(k)).max() > 0
    with pytest.raises(ValueError, match="converge_iterations: 0 is not in 1..100000"):
        dbacov.Covariance(shared_path, converge_iterations=0)
    # Self-calibrated, the cap reaches the solve at the calibrated weights too (one solve: the
    # shared snapshot has no depth-only factors).
    assert dbacov.Covariance(shared_path, converge_iterations=3).converged is False
    r = run_cli("-i", shared_path, "--csv", str(tmp_path / "c.csv"),
                "--converge-iterations", "3")
    assert r.returncode == 0, r.stderr
    assert "it reached the cap of 3 iterations (--converge-iterations raises it))" in r.stderr


def test_converge_iterations_cap_the_re_solves_at_the_calibrated_weights(tmp_path):
    # A simulated stereo snapshot (the claims true): the first solve converges within 2
    # iterations, the re-solve at the calibrated stereo weights does not, so its state is not
    # used and the warning names the cap; Python and the CLI agree.
    if not os.path.exists(SIMUL):
        pytest.fail(f"simul-dba not found: {SIMUL!r} (DBACOV_SIMUL)")
    out = tmp_path / "stereo"
    r = subprocess.run([SIMUL, "-o", str(out), "--seed", "1", "--height", "24", "--width", "32",
                        "--keyframes", "6", "--mode", "whole", "--weight-scale", "100",
                        "--sensor", "stereo", "--gauge", "droid", "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    path = str(sorted(out.glob("snapshot_*.npz"))[0])
    claims = ["--weight-scale", "100", "--gauge", "droid"]
    cov = dbacov.Covariance(path, weight_scale=100, gauge="droid", converge_iterations=2)
    rw = cov.reweighting
    assert cov.converged is True and rw["solves"] == 2 and not rw["settled"]
    assert rw["failed_solve"].startswith("2 iterations (") and \
        rw["failed_solve"].endswith(", max iterations")
    r = run_cli("-i", path, "--csv", str(tmp_path / "s.csv"),
                "--converge-iterations", "2", *claims)
    assert r.returncode == 0, r.stderr
    assert ("; the last re-solve did not converge (2 iterations (" in r.stderr and
            ", max iterations; it reached the cap of 2 iterations (--converge-iterations raises "
            "it)): the last converged state is kept)" in r.stderr), r.stderr
    assert_agree(cov, cli_marginals(path, tmp_path, "--converge-iterations", "2", *claims))


def test_bad_self_calibration_options_give_the_cli_message(shared_path, tmp_path):
    # every enum keyword shares its message with its flag (the one table, enum_names.h)
    with pytest.raises(ValueError) as e:
        dbacov.Covariance(shared_path, gauge="bogus")
    r = run_cli("-i", shared_path, "--csv", str(tmp_path / "x.csv"), "--gauge", "bogus")
    assert r.stderr.splitlines()[0] == "dba-covariance: --gauge: " + str(e.value)
    with pytest.raises(ValueError, match="self_calibrate_nodes: self-calibration nuisance nodes "
                                         "must be 0 .affine. or 2..8"):
        dbacov.Covariance(shared_path, self_calibrate_nodes=9)
    # A calibration option with the stated model would be ignored: refused, as the flags are.
    with pytest.raises(ValueError, match="self_calibrate_nodes applies to the self-calibrated "
                                         "covariance, not with stated_model=True"):
        dbacov.Covariance(shared_path, stated_model=True, self_calibrate_nodes=3)
    with pytest.raises(ValueError, match="self_calibrate_depth_noise applies"):
        dbacov.Covariance(shared_path, stated_model=True, self_calibrate_depth_noise=False)
    # The study's methods are not the product's keywords.
    with pytest.raises(TypeError):
        dbacov.Covariance(shared_path, self_calibrate_method="vce")
    with pytest.raises(TypeError):
        dbacov.Covariance(shared_path, self_calibrate=True)
    assert not os.path.exists(tmp_path / "x.csv")


def test_depth_noise_term_keyword_and_flag(shared_path, tmp_path):
    # On by default; self_calibrate_depth_noise=False is the CLI's --self-calibrate-depth-noise
    # off, to 1e-12; the term only widens the covariance.
    on = dbacov.Covariance(shared_path)
    off = dbacov.Covariance(shared_path, self_calibrate_depth_noise=False)
    assert on.self_calibration["depth_noise"] is True
    assert off.self_calibration["depth_noise"] is False
    assert on.self_calibration["depth_noise_share"] > 0
    assert off.self_calibration["depth_noise_share"] == 0
    assert "depths' 2nd-order term   +" in on.summary(full=True)
    assert "depths' 2nd-order term" not in off.summary(full=True)
    assert_agree(off, cli_marginals(shared_path, tmp_path, "--self-calibrate-depth-noise", "off"))
    assert_agree(on, cli_marginals(shared_path, tmp_path, "--self-calibrate-depth-noise", "on"))
    for k in on.keyframes[2:]:
        assert np.trace(on.marginal(k)) > np.trace(off.marginal(k))
    # The run summary says how much the term added.
    r = run_cli("-i", shared_path, "--csv", str(tmp_path / "s.csv"))
    assert r.returncode == 0, r.stderr
    share = 100 * on.self_calibration["depth_noise_share"]
    assert f"depths' second-order term median +{share:.6g} % on the calibrated trace (residual excess kurtosis median" in r.stderr
    assert on.self_calibration["depth_noise_kurtosis"] >= 0
    # DROID's residuals are heavy-tailed, and jointly so across the flow's two axes.
    assert on.self_calibration["depth_noise_cross_kurtosis"] > 0
    assert ", joint across the flow axes " in r.stderr
    # The fit check: DROID's edges' scales spread and its residuals are heavy-tailed; the CLI warns
    # with the same numbers.
    fit = on.self_calibration
    assert fit["poor_fit"] and fit["edge_scale_spread"] > 0.3
    assert f"edge white-scale spread {fit['edge_scale_spread']:.6g}, limit 0.3" in r.stderr
    assert "noise-model fit: poor on 1 of 1 snapshots" in r.stderr
    r = run_cli("-i", shared_path, "--csv", str(tmp_path / "s.csv"),
                "--self-calibrate-depth-noise", "off")
    assert r.returncode == 0 and "second-order" not in r.stderr, r.stderr


def test_stereo_edges_and_sensor_depths_get_their_own_scales(shared_path, tmp_path):
    # The shared snapshot with a stereo edge per source and sensor depths (conftest): the CLI and
    # Python agree on the covariances, the edge CSV's stereo rows and the readings' factor.
    from conftest import rgbd_arrays, stereo_arrays
    from test_dbacov import npz_arrays
    a = rgbd_arrays(stereo_arrays(npz_arrays(shared_path)))
    a["t0"] = np.asarray(int(a["ii"].min()) + 1)  # DROID's gauge: its oldest pose held
    path = tmp_path / "stereo_rgbd.npz"
    np.savez(path, **a)
    csv = tmp_path / "edges.csv"
    cov = dbacov.Covariance(str(path), gauge="droid")
    assert_agree(cov, cli_marginals(path, tmp_path, "--gauge", "droid", "--edge-csv", str(csv)))
    cal = cov.self_calibration
    assert cal["sensor_depth_rows"] > 1000
    assert cal["sensor_depth_scale"] > 0 and cal["sensor_depth_scale"] != 1.0
    edges = cal["edges"]
    stereo = np.flatnonzero(np.asarray(edges["i"]) == np.asarray(edges["j"]))
    assert len(stereo) == len(np.unique(a["ii"][a["ii"] != a["jj"]]))
    _, rows = edge_csv(csv)
    for e in stereo:  # a residual, a redundancy and a scale of their own
        assert int(rows[e]["pixels"]) > 0 and float(rows[e]["redundancy"]) > 0
        assert float(rows[e]["inflation"]) == pytest.approx(edges["inflation"][e], rel=1e-5)
    assert f"sensor depths' factor    {cal['sensor_depth_scale']:.6g}" in cov.summary(full=True)
    r = run_cli("-i", str(path), "--csv", str(tmp_path / "k.csv"), "--gauge", "droid")
    assert r.returncode == 0, r.stderr
    assert "sensor depths' variance factor median" in r.stderr + r.stdout


# --- pose rawlogs -----------------------------------------------------------------------------

def cli_rawlog(tmp_path, inputs, *options, name="cli.rawlog"):
    out = tmp_path / name
    args = []
    for i in inputs:
        args += ["-i", str(i)]
    r = run_cli(*args, "-o", str(out), "-q", *options)
    assert r.returncode == 0, r.stderr
    return gzip.decompress(out.read_bytes())


@pytest.mark.parametrize("emit", ["latest", "all"])
def test_pose_rawlog_is_the_clis_byte_for_byte(shared_path, tmp_path, emit):
    cov = dbacov.Covariance(shared_path)
    path = tmp_path / "py.rawlog"
    cov.write_pose_rawlog(str(path), emit=emit, fps=20, start_time=1.7e9)
    expected = cli_rawlog(tmp_path, [shared_path], "--emit", emit, "--fps", "20",
                          "--start-time", "1.7e9")
    assert gzip.decompress(path.read_bytes()) == expected
    assert b"DBA_COVARIANCE_CALIBRATED" in expected  # the label names the noise model
    # explicit times (what from_droid's image_times_s gives), another label, the stated model
    times = 1.7e9 + cov.snapshot.tstamp / 20
    cov.write_pose_rawlog(path, emit=emit, times=times)
    assert gzip.decompress(path.read_bytes()) == expected
    stated = dbacov.Covariance(shared_path, stated_model=True)
    dbacov.write_pose_rawlog(path, stated, emit=emit, fps=20, start_time=1.7e9)
    expected = cli_rawlog(tmp_path, [shared_path], "--emit", emit, "--fps", "20",
                          "--start-time", "1.7e9", "--stated-model")
    assert gzip.decompress(path.read_bytes()) == expected
    assert b"DBA_COVARIANCE_CALIBRATED" not in expected and b"DBA_COVARIANCE" in expected
    dbacov.write_pose_rawlog(path, stated, emit=emit, label="CAL", fps=20, start_time=1.7e9)
    assert gzip.decompress(path.read_bytes()) == cli_rawlog(
        tmp_path, [shared_path], "--emit", emit, "--fps", "20", "--start-time", "1.7e9",
        "--label", "CAL", "--stated-model")
    # One default label cannot name both models.
    with pytest.raises(dbacov.InputError, match="mix the self-calibrated and the stated"):
        dbacov.write_pose_rawlog(path, [cov, stated], fps=20)


@pytest.fixture
def sim_dir(tmp_path):
    if not os.path.exists(SIMUL):
        pytest.fail(f"simul-dba not found: {SIMUL!r} (DBACOV_SIMUL)")
    out = tmp_path / "sim"
    r = subprocess.run([SIMUL, "-o", str(out), "--snapshots", "4", "--seed", "1",
                        "--height", "24", "--width", "32", "-q"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    return out


@pytest.mark.parametrize("emit", ["latest", "all", "final"])
def test_pose_rawlog_of_a_sequence_is_the_clis(sim_dir, tmp_path, emit):
    files = sorted(sim_dir.glob("snapshot_*.npz"))
    covs = [dbacov.Covariance(str(f), weight_scale=4) for f in files]
    path = tmp_path / "py.rawlog"
    dbacov.write_pose_rawlog(path, covs, emit=emit)
    assert gzip.decompress(path.read_bytes()) == cli_rawlog(
        tmp_path, [sim_dir], "--emit", emit, "--weight-scale", "4")


def test_pose_rawlog_errors_are_the_clis_and_leave_the_file(shared_path, tmp_path):
    cov = dbacov.Covariance(shared_path)
    path = tmp_path / "py.rawlog"
    path.write_bytes(b"previous")
    with pytest.raises(dbacov.InputError) as e:
        cov.write_pose_rawlog(path)  # the shared snapshot has no times
    r = run_cli("-i", shared_path, "-o", str(tmp_path / "cli.rawlog"))
    assert r.returncode == 1
    assert "dba-covariance: error: " + str(e.value) in r.stderr.splitlines()
    assert "-o needs keyframe times" in str(e.value)
    bad = str(tmp_path / "missing" / "dir" / "x.rawlog")
    with pytest.raises(dbacov.InputError) as e:
        cov.write_pose_rawlog(bad, fps=20)
    r = run_cli("-i", shared_path, "-o", bad, "--fps", "20")
    assert r.returncode != 0 and "dba-covariance: error: " + str(e.value) in r.stderr.splitlines()
    with pytest.raises(dbacov.InputError, match=r"times has 3 values, the snapshot has 11"):
        cov.write_pose_rawlog(path, times=[1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="unknown emit mode 'bogus'"):
        cov.write_pose_rawlog(path, fps=20, emit="bogus")
    with pytest.raises(ValueError, match="fps"):
        cov.write_pose_rawlog(path, fps=0)
    assert path.read_bytes() == b"previous"  # atomic: a failed write leaves the file as it was
    assert sorted(os.listdir(tmp_path)) == ["py.rawlog"]  # and no temporary behind


def test_mrpt_is_loaded_only_by_the_first_rawlog(shared_path, tmp_path):
    # In a fresh interpreter: importing and computing load no MRPT library; the first rawlog
    # loads the bridge (libdbacov_mrpt.so, found beside libdbacov_mrpt_api.so in build/lib).
    code = f"""
import dbacov
def mrpt():
    return any("libmrpt" in line for line in open("/proc/self/maps"))
cov = dbacov.Covariance({shared_path!r})
before = (mrpt(), dbacov._dbacov._mrpt_bridge_loaded())
cov.write_pose_rawlog({str(tmp_path / "x.rawlog")!r}, fps=20)
print(before, (mrpt(), dbacov._dbacov._mrpt_bridge_loaded()))
"""
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=os.environ)
    assert r.returncode == 0, r.stderr
    assert r.stdout.split("\n")[0] == "(False, False) (True, True)"


def test_converge_re_weights_mis_claimed_sensor_depths_as_the_cli(tmp_path):
    # A simulated RGB-D snapshot whose readings' alpha is claimed 4x too high: without
    # --converge the run warns that the state is biased; with it the DBA is re-solved at the
    # calibrated alpha, in Python as in the CLI (same marginals, same factor).
    if not os.path.exists(SIMUL):
        pytest.fail(f"simul-dba not found: {SIMUL!r} (DBACOV_SIMUL)")
    out = tmp_path / "rgbd"
    r = subprocess.run([SIMUL, "-o", str(out), "--seed", "23", "--height",
                        "24", "--width", "32", "--keyframes", "6", "--mode", "whole",
                        "--weight-scale", "100", "--sensor", "rgbd", "--gauge", "droid", "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    path = str(sorted(out.glob("snapshot_*.npz"))[0])
    claimed = ["--weight-scale", "100", "--gauge", "droid", "--sensor-depth-weight", "1600"]
    r = run_cli("-i", path, "--csv", str(tmp_path / "a.csv"), *claimed)
    assert r.returncode == 0, r.stderr
    assert "--converge re-solves at the calibrated weights" in r.stderr
    assert "over-weighted depths shrink the translation" in r.stderr
    # alpha claimed 4x too low: the warning says under-weighted, not biased.
    low = ["--weight-scale", "100", "--gauge", "droid", "--sensor-depth-weight", "100"]
    r = run_cli("-i", path, "--csv", str(tmp_path / "c.csv"), *low)
    assert r.returncode == 0, r.stderr
    assert "under-weighted" in r.stderr and "shrink" not in r.stderr
    cov = dbacov.Covariance(path, weight_scale=100, gauge="droid", sensor_depth_weight=1600,
                            converge=True)
    rw = cov.reweighting
    assert rw["solves"] >= 2 and rw["settled"] and rw["last_ratio"] <= 1.02
    assert rw["failed_solve"] is None
    assert 2.5 < rw["sensor_depth_factor"] < 6.0  # the truth: 4
    assert all(f == 1.0 for f in rw["edge_factors"])  # no stereo edge
    assert_agree(cov, cli_marginals(path, tmp_path, "--converge", *claimed))
    r = run_cli("-i", path, "--csv", str(tmp_path / "b.csv"), "--converge", *claimed)
    assert r.returncode == 0, r.stderr
    assert "re-solved at the calibrated weights" in r.stderr
    assert "--converge re-solves" not in r.stderr
    # converge with the stated model: one solve at the claimed weights, nothing re-weighted.
    assert dbacov.Covariance(path, weight_scale=100, gauge="droid", sensor_depth_weight=1600,
                             converge=True, stated_model=True).reweighting is None


def test_pose_rawlog_refuses_none_and_an_empty_list(shared_path, tmp_path):
    # None in the list was a null pointer in C++ (a segfault); an empty list replaced the file
    # with an empty rawlog. Both are refused and the file is left as it was.
    cov = dbacov.Covariance(shared_path, stated_model=True)
    path = tmp_path / "x.rawlog"
    path.write_bytes(b"previous")
    with pytest.raises(TypeError, match=r"covariances\[0\] is None, expected a dbacov.Covariance"):
        dbacov.write_pose_rawlog(path, [None], fps=20)
    with pytest.raises(TypeError, match=r"covariances\[1\] is None"):
        dbacov.write_pose_rawlog(path, [cov, None], fps=20)
    with pytest.raises(dbacov.InputError, match="no covariances to write"):
        dbacov.write_pose_rawlog(path, [], fps=20)
    assert path.read_bytes() == b"previous"
    assert sorted(os.listdir(tmp_path)) == ["x.rawlog"]


def test_every_pose_held_by_the_gauge_is_zero_not_a_crash(tmp_path):
    # Two keyframes under the two-pose gauge: nothing is free, every covariance is exactly 0
    # whatever the noise model; the self-calibration (the default) used to segfault there.
    if not os.path.exists(SIMUL):
        pytest.fail(f"simul-dba not found: {SIMUL!r} (DBACOV_SIMUL)")
    out = tmp_path / "two"
    r = subprocess.run([SIMUL, "-o", str(out), "--keyframes", "2", "--mode", "whole",
                        "--height", "24", "--width", "32", "--weight-scale", "4", "-q"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    path = str(out / "snapshot_0000.npz")
    cal = dbacov.Covariance(path, weight_scale=4)
    stated = dbacov.Covariance(path, weight_scale=4, stated_model=True)
    for k in cal.keyframes:
        assert not np.any(cal.marginal(k)) and not np.any(stated.marginal(k))
    assert cal.self_calibration["optimum"]["free_dof"] == 0
    r = run_cli("-i", path, "--csv", str(tmp_path / "k.csv"), "--weight-scale", "4")
    assert r.returncode == 0, r.stderr


def test_droid_gauge_with_t0_past_the_graph_is_refused(shared_path, tmp_path):
    # DROID optimized none of the graph's poses: every covariance would be exactly 0 (it was,
    # silently). Refused as t0 = 0 is, in either noise model, by the CLI as by Python.
    from test_dbacov import npz_arrays
    a = npz_arrays(shared_path)
    a["t0"] = np.asarray(int(max(a["ii"].max(), a["jj"].max())) + 1)
    path = tmp_path / "late_t0.npz"
    np.savez(path, **a)
    for stated in (False, True):
        with pytest.raises(dbacov.NumericalError, match="is past every graph keyframe"):
            dbacov.Covariance(str(path), gauge="droid", stated_model=stated)
    r = run_cli("-i", str(path), "--csv", str(tmp_path / "k.csv"), "--gauge", "droid")
    assert r.returncode == 1, r.stderr
    assert "is past every graph keyframe (the last is 10), so DROID optimized no pose" in r.stderr
