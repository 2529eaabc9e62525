"""What `import dbacov` and the DROID-side hooks guarantee on hostile input, threads and Ctrl-C
(docs/development/reliability.md, "The Python API and the hooks"): each class of bad input over
every argument it can reach, with the exact exception and message, and that nothing else is lost.

Run by ctest (python_dbacov) with PYTHONPATH=build/python:share/droid.
"""

import io
import os
import pickle
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import dbacov
import dbacov_dump
import dbacov_online
from conftest import FakeGraph, FakeVideo

HERE = os.path.dirname(os.path.abspath(__file__))
CONVERTER = os.path.join(os.path.dirname(dbacov_dump.__file__), "convert_pickle_dumps.py")
ARRAYS = ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight", "tstamp",
          "timestamps_s", "disps_sens", "stereo_rig")


@pytest.fixture
def torch():
    return pytest.importorskip("torch", reason="python3-torch is not installed")


@pytest.fixture
def arrays(shared_path):
    """The shared snapshot's arrays plus every optional one (valid values)."""
    with np.load(shared_path) as z:
        a = {k: z[k] for k in z.files}
    a["timestamps_s"] = 100 + a["tstamp"] / 20
    a["disps_sens"] = a["disps"].copy()
    a["stereo_rig"] = dbacov_dump.DROID_STEREO_RIG.copy()
    return a


def refused(kind, key, value):
    """(bad value, exact message) of one bad kind for one argument."""
    k = f"<python>: key '{key}'"
    if kind == "complex":
        return (value.astype(np.complex128) + 1j,
                f"{k} has the complex dtype complex128: its imaginary part would be dropped; "
                "expected real numbers")
    if kind == "complex64":
        return (value.astype(np.complex64),
                f"{k} has the complex dtype complex64: its imaginary part would be dropped; "
                "expected real numbers")
    if kind == "masked":
        return (np.ma.masked_array(value, mask=np.zeros(value.shape, bool)),
                f"{k} is a NumPy masked array: its mask would be ignored; pass a plain array "
                f"(e.g. {key}.filled(0), or a weight of 0 where the data are masked)")
    if kind == "bool":
        return value.astype(bool), f"{k} has the dtype bool, expected real numbers (a float or " \
                                   "integer dtype)"
    if kind == "object":
        return value.astype(object), f"{k} has the dtype object, expected real numbers (a float " \
                                     "or integer dtype)"
    if kind == "string":
        return value.astype(str), f"{k} has the dtype " + str(value.astype(str).dtype) + \
            ", expected real numbers (a float or integer dtype)"
    raise AssertionError(kind)


def assert_same_snapshot(snap, reference):
    np.testing.assert_array_equal(dbacov.Covariance(snap, stated_model=True).marginals(),
                                  dbacov.Covariance(reference, stated_model=True).marginals())


@pytest.mark.parametrize("kind", ["complex", "complex64", "masked", "bool", "object", "string"])
def test_every_array_argument_refuses_every_lossy_kind(arrays, kind):
    originals = {k: v.copy() for k, v in arrays.items()}
    for key in ARRAYS:
        bad, message = refused(kind, key, arrays[key])
        with pytest.raises(dbacov.InputError) as e:
            dbacov.Snapshot(**dict(arrays, **{key: bad}))
        assert str(e.value) == message, key
    # Nothing else lost: the inputs are untouched and still make the same snapshot.
    for k, v in originals.items():
        np.testing.assert_array_equal(arrays[k], v)
    assert_same_snapshot(dbacov.Snapshot(**arrays), dbacov.Snapshot(**originals))


def test_torch_complex_tensors_are_refused_for_every_argument(arrays, torch):
    for key in ARRAYS:
        bad = torch.as_tensor(arrays[key].astype(np.complex64))
        with pytest.raises(dbacov.InputError, match=rf"^<python>: key '{key}' has the complex "
                                                    r"dtype complex64: its imaginary part"):
            dbacov.Snapshot(**dict(arrays, **{key: bad}))


@pytest.mark.parametrize("key", ["ii", "jj"])
def test_indices_must_be_integers_integral_floats_are_accepted(arrays, key, shared_path):
    # Integral floats (and int32, uint8) are the same snapshot.
    for dtype in (np.float64, np.float32, np.int32, np.uint8):
        same = dict(arrays, **{key: arrays[key].astype(dtype)})
        assert_same_snapshot(dbacov.Snapshot(**same), dbacov.Snapshot(**arrays))
    for value, shown in ((arrays[key][3] + 0.7, None), (np.nan, "nan"), (np.inf, "inf")):
        bad = arrays[key].astype(np.float64)
        bad[3] = value
        shown = shown or repr(float(value))
        with pytest.raises(dbacov.InputError) as e:
            dbacov.Snapshot(**dict(arrays, **{key: bad}))
        assert str(e.value) == (f"<python>: key '{key}' edge 3 is {shown} (dtype float64), not "
                                "a keyframe index: expected integers (integral floats such as "
                                "2.0 are accepted; a fraction is never rounded)")
    huge = arrays[key].astype(np.uint64)
    huge[5] = 2**64 - 1
    with pytest.raises(dbacov.InputError, match=rf"^<python>: key '{key}' edge 5 names keyframe "
                                                r"18446744073709551615, beyond any keyframe"):
        dbacov.Snapshot(**dict(arrays, **{key: huge}))


def test_id_and_t0_must_be_integers(arrays):
    s = dbacov.Snapshot(**dict(arrays, id=np.int32(4), t0=2.0))
    assert (s.id, s.t0) == (4, 2)
    for name in ("id", "t0"):
        with pytest.raises(dbacov.InputError) as e:
            dbacov.Snapshot(**dict(arrays, **{name: 1.7}))
        assert str(e.value) == (f"<python>: {name} is 1.7, not an integer: expected an integer "
                                "(integral floats such as 2.0 are accepted; a fraction is never "
                                "rounded)")
        with pytest.raises(dbacov.InputError, match=rf"^<python>: {name} is 1j \(complex\), "
                                                    "expected an integer$"):
            dbacov.Snapshot(**dict(arrays, **{name: 1j}))


def test_paths_with_a_nul_byte_are_refused_everywhere(shared_path, tmp_path):
    cov = dbacov.Covariance(shared_path, stated_model=True)
    snap = dbacov.load(shared_path)
    target = tmp_path / "out.npz"
    cut = str(target)
    for path in (cut + "\0.rawlog", (cut + "\0x").encode()):
        calls = [lambda: dbacov.load(path), lambda: dbacov.Covariance(path),
                 lambda: snap.save(path) if isinstance(path, str) else snap.save(path.decode()),
                 lambda: cov.write_pose_rawlog(path, fps=20),
                 lambda: dbacov.write_pose_rawlog(path, [cov], fps=20)]
        for call in calls:
            with pytest.raises(dbacov.InputError) as e:
                call()
            assert str(e.value) == (f"path: the path holds a NUL byte at byte {len(cut)} (after "
                                    f"'{cut}'): the system would cut the path there and use "
                                    "another file; a path cannot hold NUL")
    assert not target.exists() and os.listdir(tmp_path) == []


def test_stereo_edges_on_a_video_that_is_not_stereo_are_refused(arrays, torch, tmp_path):
    a = {k: arrays[k] for k in ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight",
                                "tstamp")}
    a["ii"], a["jj"] = a["ii"].copy(), a["jj"].copy()
    a["jj"][4] = a["ii"][4]  # an ii == jj edge
    video, graph = FakeVideo(torch, a), FakeGraph(torch, a)
    assert video.stereo is False
    message = (f"graph edge 4 links keyframe {a['ii'][4]} to itself (ii == jj), a stereo edge, "
               "but the video is not stereo (video.stereo = False): run DROID-SLAM with --stereo "
               "(DepthVideo(stereo=True)), or give the rig transform as stereo_rig= [tx ty tz qx "
               "qy qz qw] (DROID's: dbacov_dump.DROID_STEREO_RIG)")
    with pytest.raises(ValueError) as e:
        dbacov.from_droid(video, graph, include_inactive=False)
    assert str(e.value) == message
    out = tmp_path / "w.npz"
    with pytest.raises(ValueError) as e:
        dbacov_dump.dump_dba_snapshot(str(out), video, graph, 0)
    assert str(e.value) == message and not out.exists()
    del video.stereo  # no attribute at all: not declared either
    with pytest.raises(ValueError, match="video.stereo = None"):
        dbacov.from_droid(video, graph, include_inactive=False)
    # Declared: the video is stereo, or the rig is given.
    video.stereo = True
    s = dbacov.from_droid(video, graph, include_inactive=False)
    assert s.is_stereo
    video.stereo = False
    rig = np.array([-0.2, 0, 0, 0, 0, 0, 1.0])
    assert dbacov.from_droid(video, graph, include_inactive=False, stereo_rig=rig).is_stereo


def test_snapshots_from_8_threads_keep_every_reference_count(arrays):
    # Arrays of the snapshot dtypes are read in place: the binding holds references to them.
    kw = {k: np.ascontiguousarray(v, dtype=dbacov._DTYPES[k]) for k, v in arrays.items()
          if k in ARRAYS}
    before = {k: sys.getrefcount(v) for k, v in kw.items()}
    errors = []

    def work():
        try:
            for _ in range(25):
                s = dbacov.Snapshot(**kw)
                assert s.is_stereo and s.is_rgbd and s.timestamps_s is not None
        except BaseException as e:  # noqa: BLE001 -- reported below
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert {k: sys.getrefcount(v) for k, v in kw.items()} == before


LONG = r'''
import sys, time
import numpy as np
import dbacov
with np.load(sys.argv[1]) as z:
    a = {k: z[k] for k in z.files}
k, rep = 4, 2  # 16x the pixels, every edge twice: about 18 s uninterrupted on 2 cores
b = dict(a)
b["disps"] = np.repeat(np.repeat(a["disps"], k, 1), k, 2)
b["intrinsics"] = a["intrinsics"] * k
b["target"] = np.concatenate([np.repeat(np.repeat(a["target"], k, 2), k, 3) * k] * rep)
b["weight"] = np.concatenate([np.repeat(np.repeat(a["weight"], k, 2), k, 3)] * rep)
b["ii"], b["jj"] = np.concatenate([a["ii"]] * rep), np.concatenate([a["jj"]] * rep)
snap = dbacov.Snapshot(**b)
print("start", flush=True)
t = time.monotonic()
try:
    dbacov.Covariance(snap)
    print("finished", flush=True)
except KeyboardInterrupt:
    print("interrupted", flush=True)
# the process goes on: the next computation is whole
print("after", dbacov.Covariance(sys.argv[1]).marginals().shape, flush=True)
'''


def test_ctrl_c_stops_a_long_covariance_and_the_process_goes_on(shared_path):
    p = subprocess.Popen([sys.executable, "-c", LONG, shared_path], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True)
    try:
        assert p.stdout.readline() == "start\n"
        time.sleep(1.0)
        sent = time.monotonic()
        p.send_signal(signal.SIGINT)
        assert p.stdout.readline() == "interrupted\n"
        stopped = time.monotonic() - sent
        out, err = p.communicate(timeout=120)
    finally:
        p.kill()
    assert out == "after (10, 6, 6)\n" and p.returncode == 0, err
    # "interrupted", not "finished": the call itself stopped (about 18 s uninterrupted on 2
    # cores); the engine's loops check between items, one source keyframe's work (1-2 s here).
    assert stopped < 10.0


def test_unknown_keywords_name_themselves_and_the_valid_ones(shared_path, arrays, torch):
    cov = dbacov.Covariance(shared_path, stated_model=True)
    covariance = ", ".join(("snapshot",) + dbacov.COVARIANCE_KEYWORDS)
    cases = [
        (lambda: dbacov.Covariance(shared_path, weightscale=2),
         "Covariance() got an unknown keyword argument 'weightscale' (did you mean "
         f"'weight_scale'?); valid keywords: {covariance}"),
        (lambda: dbacov.check_options(xyz=1),
         "check_options() got an unknown keyword argument 'xyz'; valid keywords: "
         + ", ".join(dbacov.COVARIANCE_KEYWORDS)),
        (lambda: dbacov.load(shared_path, mmap=True),
         "load() got an unknown keyword argument 'mmap'; valid keywords: path"),
        (lambda: dbacov.Snapshot(**dict(arrays, timestamp_s=arrays["tstamp"])),
         "Snapshot() got an unknown keyword argument 'timestamp_s' (did you mean "
         "'timestamps_s'?); valid keywords: poses, disps, intrinsics, ii, jj, target, weight, "
         "tstamp, timestamps_s, id, disps_sens, stereo_rig, t0, source"),
        (lambda: cov.write_pose_rawlog("x.rawlog", fsp=20),
         "write_pose_rawlog() got an unknown keyword argument 'fsp' (did you mean 'fps'?); "
         "valid keywords: emit, label, fps, start_time, times"),
        (lambda: dbacov.write_pose_rawlog("x.rawlog", [cov], time=[1]),
         "write_pose_rawlog() got an unknown keyword argument 'time'; valid keywords: path, "
         "covariances, emit, label, fps, start_time"),
        (lambda: dbacov.from_droid(None, None, inactive=True),
         "from_droid() got an unknown keyword argument 'inactive' (did you mean "
         "'include_inactive'?); valid keywords: video, graph, include_inactive, record, "
         "image_times_s, stereo_rig, snapshot_id"),
    ]
    for call, message in cases:
        with pytest.raises(TypeError) as e:
            call()
        assert str(e.value) == message
    # The list is the binding's own: every keyword of Covariance's C++ signature, in order.
    doc = dbacov._Covariance.__init__.__doc__
    sig = doc[doc.index("*,") + 2:doc.index(") -> None")]
    assert tuple(p.split(":")[0].strip() for p in sig.split(", ") if ":" in p) == \
        dbacov.COVARIANCE_KEYWORDS


def test_check_options_gives_covariances_messages_without_a_snapshot():
    assert dbacov.check_options(preset="paper", gauge="minimal", weight_scale=2) is None
    for kw, message in (({"gauge": "foo"}, "unknown gauge 'foo', expected two-pose, minimal or "
                                           "droid"),
                        ({"preset": "x"}, "unknown preset 'x', expected droid, paper or dpvo"),
                        ({"preset": "dpvo"}, "preset 'dpvo' is that of DPVO's patch graphs, which "
                                             "the programs and the Python module do not read "
                                             "yet; a DROID snapshot takes 'droid' or 'paper'"),
                        ({"weight_scale": 0}, "weight scale must be finite and > 0")):
        with pytest.raises(ValueError) as e:
            dbacov.check_options(**kw)
        assert str(e.value) == message


# --- the hooks ----------------------------------------------------------------------------------

class BadStr(Exception):
    def __str__(self):
        raise RuntimeError("__str__ itself fails")


def test_hooks_survive_an_exception_whose_str_raises(arrays, torch, tmp_path, monkeypatch):
    a = {k: arrays[k] for k in ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight",
                                "tstamp")}
    video, graph = FakeVideo(torch, a), FakeGraph(torch, a)

    def boom(*args, **kwargs):
        raise BadStr()

    err = io.StringIO()
    dumper = dbacov_dump.DbaDumper(tmp_path / "out", stream=err)
    monkeypatch.setattr(dbacov_dump, "dump_dba_snapshot", boom)
    assert dumper(video, graph, 3) is None and dumper(video, graph, 4) is None
    monkeypatch.undo()
    assert dumper.failures == 2
    assert err.getvalue() == ("dbacov_dump: snapshot 3 not written (BadStr: <BadStr whose "
                              "message cannot be printed: its __str__ raised>); DROID-SLAM goes "
                              "on, further failures of this kind are not reported\n")
    assert dumper(video, graph, 5) is not None  # and it goes on

    err = io.StringIO()
    printer = dbacov_online.KeyframeSigmaPrinter(out=io.StringIO(), stream=err, stated_model=True)
    monkeypatch.setattr(dbacov, "Covariance", boom)
    assert printer(video, graph, 7) is None
    monkeypatch.undo()
    assert printer.failures == 1
    assert err.getvalue() == ("dbacov_online: update 7: no sigma (BadStr: <BadStr whose message "
                              "cannot be printed: its __str__ raised>); DROID-SLAM goes on, "
                              "further failures of this kind are not reported\n")
    assert printer(video, graph, 8) is not None


FULL_DISK = r'''
import resource, signal, sys
import numpy as np
import torch
import dbacov_dump
from conftest import FakeGraph, FakeVideo
with np.load(sys.argv[1]) as z:
    a = {k: z[k] for k in ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight", "tstamp")}
dumper = dbacov_dump.DbaDumper(sys.argv[2], pattern="window.npz")
assert dumper(FakeVideo(torch, a), FakeGraph(torch, a), 0)  # the previous output
# Writes now fail as on a full disk (EFBIG instead of ENOSPC, as the CLI's tests do).
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (20000, 20000))
for count in range(1, 6):
    assert dumper(FakeVideo(torch, a), FakeGraph(torch, a), count) is None
import gc
gc.collect()
print(dumper.written, dumper.failures)
'''


def test_a_full_disk_is_reported_once_and_keeps_the_previous_snapshot(shared_path, tmp_path):
    out = tmp_path / "out"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.environ.get("PYTHONPATH", ""), HERE]))
    r = subprocess.run([sys.executable, "-c", FULL_DISK, shared_path, str(out)],
                       capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stderr
    assert r.stdout == "1 5\n"
    assert r.stderr == ("dbacov_dump: snapshot 1 not written (OSError: [Errno 27] File too "
                        "large); DROID-SLAM goes on, further failures of this kind are not "
                        "reported\n")  # once, and no traceback of a half-written archive
    assert os.listdir(out) == ["window.npz"]  # no temporary left
    with np.load(out / "window.npz") as z:  # the previous snapshot, whole
        assert int(z["id"]) == 0 and z["target"].shape == (58, 2, 49, 61)


def test_converter_refuses_duplicate_tstamps_naming_pickle_and_keyframes(tmp_path):
    rng = np.random.default_rng(5)
    n, e, h, w = 4, 5, 3, 4
    ii = np.array([0, 1, 2, 3, 0])
    jj = np.array([1, 2, 3, 0, 2])

    def dump(tstamp):
        return {"id": 3, "graph_data": {"ii": ii, "jj": jj},
                "predicted": rng.normal(size=(e, 2, h, w)).astype(np.float32),
                "c_map": rng.uniform(size=(e, 2, h, w)).astype(np.float32),
                "poses": np.tile([0, 0, 0, 0, 0, 0, 1.0], (n, 1)),
                "disps": np.ones((n, h, w), np.float32),
                "intrinsics": np.array([4.0, 4, 2, 1.5]), "tstamp": np.asarray(tstamp, float)}

    src = tmp_path / "in"
    src.mkdir()
    for name, ts in (("a.pkl", [0, 2, 2, 6]), ("b.pkl", [0, 2, 4, 6]), ("c.pkl", [9, 1, 5, 1])):
        with open(src / name, "wb") as f:
            pickle.dump(dump(ts), f)
    r = subprocess.run([sys.executable, "-B", CONVERTER, str(src), "-o", str(tmp_path / "out"),
                        "-q"], capture_output=True, text=True)
    assert r.returncode == 1
    assert r.stderr.splitlines() == [
        f"convert_pickle_dumps.py: error: {src / 'a.pkl'}: key 'tstamp' gives keyframes 1 and 2 "
        "the same value 2: a keyframe is identified by its tstamp (the image index), expected "
        "distinct values",
        f"convert_pickle_dumps.py: error: {src / 'c.pkl'}: key 'tstamp' gives keyframes 1 and 3 "
        "the same value 1: a keyframe is identified by its tstamp (the image index), expected "
        "distinct values"]
    assert sorted(os.listdir(tmp_path / "out")) == ["b.npz"]  # the good one is still written
    dbacov.load(tmp_path / "out" / "b.npz")


def test_the_hooks_reader_refuses_lossy_tensors_of_every_attribute(arrays, torch):
    a = {k: arrays[k] for k in ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight",
                                "tstamp")}
    for owner, attr in (("video", "poses"), ("video", "disps"), ("video", "intrinsics"),
                        ("video", "tstamp"), ("video", "disps_sens"), ("graph", "ii"),
                        ("graph", "jj"), ("graph", "target"), ("graph", "weight")):
        for kind in ("complex", "bool"):
            video, graph = FakeVideo(torch, a), FakeGraph(torch, a)
            obj = video if owner == "video" else graph
            t = getattr(obj, attr)
            setattr(obj, attr, t.to(torch.complex64) if kind == "complex" else t > 0)
            message = (f"{owner}.{attr} has the complex dtype complex64: its imaginary part "
                       "would be dropped; expected real numbers" if kind == "complex" else
                       f"{owner}.{attr} has the dtype bool, expected real numbers (a float or "
                       "integer dtype)")
            with pytest.raises(ValueError) as e:
                dbacov.from_droid(video, graph, include_inactive=False)
            assert str(e.value) == message
    for attr in ("ii", "jj"):
        video, graph = FakeVideo(torch, a), FakeGraph(torch, a)
        t = getattr(graph, attr).to(torch.float64)
        t[6] += 0.5
        setattr(graph, attr, t)
        with pytest.raises(ValueError) as e:
            dbacov.from_droid(video, graph, include_inactive=False)
        assert str(e.value) == (f"graph.{attr}[6] is {float(t[6])!r}, not a keyframe index: "
                                "expected integers (integral floats such as 2.0 are accepted; "
                                "a fraction is never rounded)")
        setattr(graph, attr, t.round())  # integral floats: the same snapshot
        np.testing.assert_array_equal(
            dbacov.Covariance(dbacov.from_droid(video, graph, include_inactive=False),
                              stated_model=True).marginals().shape, (10, 6, 6))


# --- the hook's tensor reader under random hostile tensors ---------------------------------------

def hostile(rng, a, torch):
    """DROID's objects with one random defect: a shape, dtype, value or attribute."""
    video, graph = FakeVideo(torch, a), FakeGraph(torch, a)
    what = rng.integers(0, 12)
    name = rng.choice(["poses", "disps", "intrinsics", "tstamp"])
    if what == 0:
        setattr(video, name, getattr(video, name)[..., :1])
    elif what == 1:
        setattr(video, name, getattr(video, name).to(torch.complex64))
    elif what == 2:
        t = getattr(video, name).clone()
        t.view(-1)[rng.integers(0, t.numel())] = float(rng.choice([np.nan, np.inf, -1e39]))
        setattr(video, name, t)
    elif what == 3:
        video.counter.value = int(rng.choice([0, -3, 17, 10**6]))
    elif what == 4:
        g = rng.choice(["ii", "jj"])
        t = getattr(graph, g).clone()
        t[rng.integers(0, t.numel())] = int(rng.choice([-1, 11, 2**40]))
        setattr(graph, g, t)
    elif what == 5:
        setattr(graph, rng.choice(["ii", "jj"]), graph.ii.to(torch.float32) + 0.5)
    elif what == 6:
        setattr(graph, rng.choice(["target", "weight"]), graph.weight[..., :1])
    elif what == 7:
        graph.weight = graph.weight.to(torch.bool)
    elif what == 8:
        delattr(graph, rng.choice(["ii", "target", "weight"]))
    elif what == 9:
        graph.ii, graph.jj = graph.ii[:0], graph.jj[:0]
    elif what == 10:
        video.tstamp = video.tstamp.clone()
        video.tstamp[2] = video.tstamp[1]
    else:
        graph.target = graph.target.to(torch.float64) * 1e300
    return video, graph


def test_hostile_droid_tensors_give_value_errors_and_never_stop_the_hook(arrays, torch):
    a = {k: arrays[k] for k in ("poses", "disps", "intrinsics", "ii", "jj", "target", "weight",
                                "tstamp")}
    rng = np.random.default_rng(47)
    dumper_err = io.StringIO()
    printer = dbacov_online.KeyframeSigmaPrinter(out=io.StringIO(), stream=dumper_err,
                                                 stated_model=True)
    kinds = set()
    for trial in range(60):
        video, graph = hostile(rng, a, torch)
        try:
            dbacov.from_droid(video, graph, include_inactive=False)
        except (ValueError, AttributeError) as e:  # InputError and KeyframeTimeError are too
            kinds.add(type(e).__name__)
        assert printer(video, graph, trial) is None or True  # never raises
    assert "InputError" in kinds and "ValueError" in kinds
