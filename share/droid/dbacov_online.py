"""Online example: print each new keyframe's pose uncertainty while DROID-SLAM's frontend runs.

After every frontend update (where ``dbacov_dump.DbaDumper`` would write a snapshot), the DBA
factor graph is handed to ``import dbacov`` in-process (``dbacov.from_droid``: no file), and for
the newest graph keyframe, if it was not reported yet, one line is printed with the standard
deviations of its marginal covariance (tangent [rho; phi] of T_wc, conventions §3)::

    dbacov: keyframe 10 frame 55 t 2.750000 s: sigma_t 0.168262822 0.1578579657 0.1000953133 sigma_r_deg 13.29278334 11.44688938 4.644450197

sigma_t are the x y z translation std-devs in the map's (scale-free) unit, sigma_r_deg the rotation
std-devs about x y z in degrees, in the camera axes, relative to the gauge (``dba-covariance``'s
options as keywords: preset droid by default, i.e. DROID's weight scale 0.001). ``digits``
significant digits (default 10). Like the dump hook, it never stops SLAM: every failure is caught,
reported once per kind on stderr, and counted (``failures``).

With a DROID-SLAM checkout (its ``droid_slam`` importable) and dbacov built::

    PYTHONPATH=/path/to/dbacov/build/python:/path/to/dbacov/share/droid:/path/to/DROID-SLAM/droid_slam \\
        python /path/to/dbacov/share/droid/dbacov_online.py [--fps 20] [--weight-scale W] -- \\
        /path/to/DROID-SLAM/demo.py --imagedir=data/abandonedfactory --calib=calib/tartan.txt

runs DROID's script (everything after ``--``, with its own arguments) with the frontend's update
method wrapped (``install()``): after each ``DroidFrontend._update`` (``__update`` before 2025) the
printer is called with the frontend's video, graph and counter. In your own code::

    from dbacov_online import KeyframeSigmaPrinter, install
    install(KeyframeSigmaPrinter(weight_scale=0.001))   # before DROID builds its frontend
"""

import argparse
import contextlib
import functools
import math
import os
import runpy
import sys

import numpy as np

from dbacov_dump import exception_text

__all__ = ["KeyframeSigmaPrinter", "keyframe_sigmas", "install", "main"]


def keyframe_sigmas(cov, keyframe):
    """(sigma_t (3,), sigma_r_deg (3,)) from the keyframe's 6x6 marginal covariance."""
    d = np.diag(cov.marginal(keyframe))
    return np.sqrt(d[:3]), np.degrees(np.sqrt(d[3:]))


class KeyframeSigmaPrinter:
    """The frontend hook: call it once per update, as ``DbaDumper``; prints one line per new
    keyframe on `out` (default stdout) and never raises.

    `image_times_s` (every image's time, by image index) adds the keyframe time; further keywords
    are dbacov.Covariance's (preset, weight_scale, gauge, stated_model, ...): the sigmas are
    self-calibrated from each update's residuals unless stated_model=True. The keywords are
    checked here (dbacov.check_options: TypeError, ValueError), not at the first update."""

    def __init__(self, out=None, image_times_s=None, include_inactive=True, digits=10,
                 stream=None, **covariance_options):
        self.out, self.stream = out, stream
        self.image_times_s = image_times_s
        self.include_inactive, self.digits = include_inactive, int(digits)
        self.options = dict(covariance_options)
        self.options.setdefault("depth_sigma", False)  # only the pose marginal is needed
        try:
            import dbacov
        except ImportError:  # reported at each update, where the printer never raises
            dbacov = None
        if dbacov is not None:
            # A bad option is the caller's error, raised here, before DROID runs; at each update
            # it would only be a sigma-less line.
            dbacov.check_options(**self.options)
        self.printed, self.failures = 0, 0
        self._seen = set()      # true frame indices (tstamp) already reported
        self._reported = set()  # failure kinds already reported
        self._record = None

    def __call__(self, video, graph, count=None):
        try:
            import dbacov  # here, so that a missing module is a reported failure, not a crash
            if self._record is None:
                self._record = dbacov.KeyframeRecord()
            snap = dbacov.from_droid(video, graph, record=self._record,
                                     include_inactive=self.include_inactive,
                                     image_times_s=self.image_times_s, snapshot_id=count)
            graph_kf = snap.graph_keyframes
            k = max(graph_kf)
            frame = float(snap.tstamp[k])
            if frame in self._seen:
                return None
            cov = dbacov.Covariance(snap, **self.options)
            st, sr = keyframe_sigmas(cov, k)
            self._seen.add(frame)
            g = f".{self.digits}g"
            t = "" if snap.timestamps_s is None else f" t {snap.timestamps_s[k]:.6f} s"
            line = (f"dbacov: keyframe {k} frame {frame:g}{t}: sigma_t "
                    + " ".join(format(v, g) for v in st) + " sigma_r_deg "
                    + " ".join(format(v, g) for v in sr))
            print(line, file=self.out or sys.stdout, flush=True)
            self.printed += 1
            return line
        except Exception as exc:  # noqa: BLE001 -- the hook must never stop SLAM
            self.failures += 1
            if type(exc).__name__ == "KeyframeTimeError":
                self._record = None  # start afresh at the next update, as DbaDumper does
            text = exception_text(exc)
            kind = (type(exc).__name__, text.split(":")[0])
            if kind not in self._reported:
                self._reported.add(kind)
                with contextlib.suppress(Exception):
                    print(f"dbacov_online: update {count}: no sigma ({type(exc).__name__}: "
                          f"{text}); DROID-SLAM goes on, further failures of this kind are not "
                          "reported", file=self.stream or sys.stderr, flush=True)
            return None


def install(hook, frontend_class=None):
    """Wraps DroidFrontend's update method (``_update``, or ``_DroidFrontend__update`` in
    releases before 2025) so that `hook(video, graph, count)` runs after each update. Returns the
    class. The hook's own failures never propagate (KeyframeSigmaPrinter catches them; any other
    hook is guarded here too)."""
    if frontend_class is None:
        try:  # DROID-SLAM's droid_slam/ on sys.path, as its demo.py puts it
            from droid_frontend import DroidFrontend as frontend_class
        except ImportError:  # droid_slam installed as a package
            from droid_slam.droid_frontend import DroidFrontend as frontend_class
    names = ("_update", f"_{frontend_class.__name__.lstrip('_')}__update")  # __update, mangled
    name = next((n for n in names if n in vars(frontend_class)), None)
    if name is None:
        raise AttributeError(f"{frontend_class.__name__} has no _update / __update method")
    original = getattr(frontend_class, name)
    if getattr(original, "_dbacov_hook", None) is not None:
        original = original.__wrapped__  # installed twice: replace the hook

    @functools.wraps(original)
    def update(self, *args, **kwargs):
        result = original(self, *args, **kwargs)
        with contextlib.suppress(Exception):
            hook(self.video, self.graph, getattr(self, "count", None))
        return result

    update._dbacov_hook = hook
    setattr(frontend_class, name, update)
    return frontend_class


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    ours, script = (argv[:argv.index("--")], argv[argv.index("--") + 1:]) if "--" in argv \
        else (argv, [])
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                usage="dbacov_online.py [options] -- DROID_SCRIPT.py [ARGS...]")
    p.add_argument("--preset", default="droid")
    p.add_argument("--weight-scale", type=float)
    p.add_argument("--gauge")
    p.add_argument("--stated-model", action="store_true",
                   help="sigma of the noise DROID states (confidences x weight scale) instead "
                        "of the self-calibrated default (dba-covariance --stated-model)")
    # dba-covariance's calibration options (Covariance's keywords).
    p.add_argument("--self-calibrate-nodes", type=int,
                   help="the per-edge flow-error field: 0 = affine, 2..8 = G x G spline")
    p.add_argument("--self-calibrate-depth-noise", choices=["on", "off"])
    p.add_argument("--converge", action="store_true",
                   help="solve each update's DBA to the optimum of its factors first")
    p.add_argument("--converge-iterations", type=int,
                   help="the --converge solve's iteration cap (default 200); implies --converge")
    p.add_argument("--fps", type=float,
                   help="rate of the frames DROID is fed (after its --stride): prints the "
                        "keyframe time tstamp / fps")
    p.add_argument("--digits", type=int, default=10)
    o = p.parse_args(ours)
    # The ranges dba-covariance checks (and Covariance would only report per update, as a
    # sigma-less line, after DROID has run): refused here, before DROID starts.
    for key, ok, what in (("self_calibrate_nodes", lambda n: n == 0 or 2 <= n <= 8,
                           "0 (affine) or 2..8"),
                          ("converge_iterations", lambda n: 1 <= n <= 100000, "1..100000")):
        value = getattr(o, key)
        if value is not None and not ok(value):
            p.error(f"--{key.replace('_', '-')}: {value} is not in {what}")
    if o.fps is not None and not (math.isfinite(o.fps) and o.fps > 0):
        p.error(f"--fps {o.fps:g}: expected a finite positive frame rate (frames per second)")
    if not 1 <= o.digits <= 17:
        p.error(f"--digits: {o.digits} is not in 1..17")
    options = {"preset": o.preset}
    for key in ("weight_scale", "gauge"):
        if getattr(o, key) is not None:
            options[key] = getattr(o, key)
    if o.stated_model:
        if o.self_calibrate_nodes is not None or o.self_calibrate_depth_noise is not None:
            p.error("--self-calibrate-nodes and --self-calibrate-depth-noise apply to the "
                    "self-calibrated sigma, not with --stated-model")
        options["stated_model"] = True
    if o.self_calibrate_nodes is not None:
        options["self_calibrate_nodes"] = o.self_calibrate_nodes
    if o.self_calibrate_depth_noise is not None:
        options["self_calibrate_depth_noise"] = o.self_calibrate_depth_noise == "on"
    if o.converge:
        options["converge"] = True
    if o.converge_iterations is not None:
        options["converge_iterations"] = o.converge_iterations
    # Every option as Covariance would check it at the first update, refused now, before DROID.
    try:
        import dbacov
    except ImportError as e:
        p.error(f"cannot import dbacov ({exception_text(e)}): put dbacov's build/python on "
                "PYTHONPATH")
    for key, value in options.items():
        try:
            dbacov.check_options(**{key: value})
        except (ValueError, TypeError) as e:
            flag = "--" + key.replace("_", "-")
            shown = "" if isinstance(value, bool) else f" {value}"
            p.error(f"{flag}{shown}: {exception_text(e)}")
    try:
        dbacov.check_options(**options)
    except (ValueError, TypeError) as e:
        p.error(exception_text(e))
    if not script:
        p.error("give DROID-SLAM's script after --, e.g. -- demo.py --imagedir=... --calib=...")
    times = None if o.fps is None else np.arange(1_000_000) / o.fps
    install(KeyframeSigmaPrinter(image_times_s=times, digits=o.digits, **options))
    sys.argv = script
    sys.path.insert(0, os.path.dirname(os.path.abspath(script[0])))
    runpy.run_path(script[0], run_name="__main__")
    return 0


if __name__ == "__main__":
    sys.exit(main())
