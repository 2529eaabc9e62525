// `import dbacov` — the C++ part (dbacov._dbacov): snapshots, the covariance engine and the
// project's errors for Python. The pure-Python wrapper (dbacov/__init__.py) adds torch tensors,
// keyword defaults and dbacov.from_droid.
//
// Arrays in: any NumPy array (or what np.asarray reads) is viewed in place with the GIL held and
// converted by the C++ entry snapshotFromArrays (snapshot_arrays.h) without it, refusing what a
// conversion would change (complex, masks, fractional indices); the Snapshot then owns one copy,
// as the engine works on its own storage. No Python object is touched without the GIL. Arrays
// out: NumPy arrays owning their data. The GIL is released while the engine computes, and the
// engine's loops check for signals (Ctrl-C raises KeyboardInterrupt from inside the call).
// InputError → dbacov.InputError (a ValueError), NumericalError → dbacov.NumericalError (an
// ArithmeticError), std::invalid_argument → ValueError, same messages.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "dbacov/app/covariance_app.h"
#include "dbacov/app/outputs.h"
#include "dbacov/app/self_calibration_options.h"
#include "dbacov/core/covariance.h"
#include "dbacov/core/errors.h"
#include "dbacov/core/keyframe_times.h"
#include "dbacov/core/options.h"
#include "dbacov/core/pipeline.h"
#include "dbacov/core/snapshot.h"
#include "dbacov/core/threads.h"
#include "dbacov/io/snapshot_npz.h"
#include "snapshot_arrays.h"

namespace py = pybind11;
using namespace dbacov;
using dbacov::app::SelfCalibrationAppOptions;

namespace {

/// An array argument as the C++ entry reads it (snapshot_arrays.h), taken with the GIL held:
/// anything NumPy can read as an array (np.asarray), C-contiguous and in native byte order; the
/// array is kept in `keep` (alive until the snapshot is built). A masked array is passed on as
/// such, for the entry to refuse.
python::ArrayView viewOf(const py::handle& x, const char* key, const std::string& source,
                         std::vector<py::array>& keep) {
  python::ArrayView v;
  const py::module_ np = py::module_::import("numpy");
  if (py::isinstance(x, py::module_::import("numpy.ma").attr("MaskedArray"))) {
    v.masked = true;
    return v;
  }
  py::array a;
  try {
    a = np.attr("asarray")(x);
    if (!a.dtype().attr("isnative").cast<bool>())
      a = a.attr("astype")(a.dtype().attr("newbyteorder")("="));
    a = np.attr("ascontiguousarray")(a);
  } catch (py::error_already_set& e) {
    throw InputError(source + ": key '" + key + "' is not an array (" +
                     py::str(py::type::handle_of(x).attr("__name__")).cast<std::string>() +
                     "): " + e.what());
  }
  v.kind = a.dtype().kind();
  v.itemsize = static_cast<int>(a.itemsize());
  v.dtype = py::str(a.dtype()).cast<std::string>();
  for (py::ssize_t k = 0; k < a.ndim(); ++k) v.shape.push_back(a.shape(k));
  v.data = a.data();
  keep.push_back(std::move(a));
  return v;
}

/// Snapshot(...): the views with the GIL, then the entry without it. Every Python object (the
/// arrays in `keep`, the arguments) is released by the caller, with the GIL held.
std::shared_ptr<Snapshot> makeSnapshot(const py::object& poses, const py::object& disps,
                                       const py::object& intrinsics, const py::object& ii,
                                       const py::object& jj, const py::object& target,
                                       const py::object& weight, const py::object& tstamp,
                                       const py::object& timestamps_s,
                                       std::optional<std::int64_t> id, const py::object& disps_sens,
                                       const py::object& stereo_rig, std::optional<std::int64_t> t0,
                                       const std::string& source) {
  std::vector<py::array> keep;
  python::SnapshotArrays in;
  in.source = source;
  in.poses = viewOf(poses, "poses", source, keep);
  in.disps = viewOf(disps, "disps", source, keep);
  in.intrinsics = viewOf(intrinsics, "intrinsics", source, keep);
  in.ii = viewOf(ii, "ii", source, keep);
  in.jj = viewOf(jj, "jj", source, keep);
  in.target = viewOf(target, "target", source, keep);
  in.weight = viewOf(weight, "weight", source, keep);
  in.tstamp = viewOf(tstamp, "tstamp", source, keep);
  if (!timestamps_s.is_none()) in.timestamps_s = viewOf(timestamps_s, "timestamps_s", source, keep);
  if (!disps_sens.is_none()) in.disps_sens = viewOf(disps_sens, "disps_sens", source, keep);
  if (!stereo_rig.is_none()) in.stereo_rig = viewOf(stereo_rig, "stereo_rig", source, keep);
  in.id = id;
  in.t0 = t0;
  std::shared_ptr<Snapshot> s;
  {
    py::gil_scoped_release release;
    s = std::make_shared<Snapshot>(python::snapshotFromArrays(in));
  }
  return s;
}

/// A signal handler raised (Ctrl-C: KeyboardInterrupt); the Python error is pending.
struct Interrupted {};

/// Runs f() without the GIL; the engine's parallel loops check for signals on the way (with the
/// GIL, at most every 20 ms), and a handler's exception (KeyboardInterrupt) stops the
/// computation and is raised here.
template <typename F>
auto interruptible(F&& f) -> decltype(f()) {
  try {
    py::gil_scoped_release release;
    const ScopedInterruptCheck check([] {
      py::gil_scoped_acquire gil;
      if (PyErr_CheckSignals() != 0) throw Interrupted{};
    });
    return f();
  } catch (const Interrupted&) {
    throw py::error_already_set();
  }
}

py::array_t<double> matrix(const Eigen::MatrixXd& m) {
  py::array_t<double> out({m.rows(), m.cols()});
  auto r = out.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i)
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  return out;
}

/// The engine and the options it was made with.
struct PyCovariance {
  std::shared_ptr<const Snapshot> snapshot;
  std::unique_ptr<DbaCovariance> cov;
  DbaOptions options;
  bool depth_sigma = true;
  std::optional<SelfCalibration> calibration;  ///< unless stated_model=True
  std::optional<DbaSolverSummary> solve;       ///< converge=True
  std::optional<CalibratedSolve> reweighted;   ///< converge=True, self-calibrated
};

/// The noise-model keywords into the apps' options (SelfCalibrationAppOptions::options(): the
/// same checks and messages as dba-covariance's flags, named by the keyword).
SelfCalibrationAppOptions selfCalibrationOptions(bool stated_model, std::optional<int> nodes,
                                                 std::optional<bool> depth_noise, bool converge,
                                                 std::optional<int> converge_iterations) {
  SelfCalibrationAppOptions o;
  o.stated_model = stated_model;
  if (nodes) {
    // The core's own check (SelfCalibrationOptions::validate), named by the keyword.
    SelfCalibrationOptions check;
    check.nuisance_nodes = *nodes;
    try {
      check.validate();
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("self_calibrate_nodes: ") + e.what());
    }
    o.nodes = *nodes;
  }
  if (depth_noise) o.depth_noise = *depth_noise ? "on" : "off";
  if (stated_model && (nodes || depth_noise))
    throw std::invalid_argument(
        std::string(nodes ? "self_calibrate_nodes" : "self_calibrate_depth_noise") +
        " applies to the self-calibrated covariance, not with "
        "stated_model=True");
  o.converge = converge || converge_iterations.has_value();
  if (converge_iterations) {
    if (*converge_iterations < 1 ||
        *converge_iterations > 100000)  // dba-covariance's integerIn(1, 100000)
      throw std::invalid_argument("converge_iterations: " + std::to_string(*converge_iterations) +
                                  " is not in 1..100000");
    o.converge_iterations = *converge_iterations;
  }
  o.options();
  return o;
}

py::dict calibrationDict(const SelfCalibration& cal) {
  py::dict d;
  d["method"] = cal.method;
  d["global_scale"] = cal.global_scale;
  d["passes"] = cal.passes;
  d["sensor_depth_scale"] = cal.sensor_depth_scale;  // RGB-D readings' variance factor (1: none)
  d["sensor_depth_rows"] = cal.sensor_depth_rows;
  d["field_sigma"] = cal.nuisance_sigma;
  d["field_fine_sigma"] = cal.nuisance_fine_sigma;
  d["field_params"] = cal.nuisance_params;
  py::dict opt;
  opt["gradient_norm"] = cal.optimum.gradient_norm;
  opt["step_sigma"] = cal.optimum.step_sigma;
  opt["max_step_sigma"] = cal.optimum.max_step_sigma;
  opt["free_dof"] = cal.optimum.free_dof;
  opt["unreliable"] = cal.optimum.unreliable();
  d["optimum"] = opt;
  // One array per EdgeCalibration field, in edge order (the columns of --edge-csv).
  const std::size_t n = cal.edges.size();
  auto column = [&](auto get) {
    using T = decltype(get(cal.edges.front()));
    py::array_t<T> a(static_cast<py::ssize_t>(n));
    T* p = a.mutable_data();
    for (std::size_t e = 0; e < n; ++e) p[e] = get(cal.edges[e]);
    return a;
  };
  py::dict edges;
  if (n > 0) {
    edges["edge"] = column([](const EdgeCalibration& e) { return std::int64_t(e.edge); });
    edges["i"] = column([](const EdgeCalibration& e) { return std::int64_t(e.i); });
    edges["j"] = column([](const EdgeCalibration& e) { return std::int64_t(e.j); });
    edges["pixels"] = column([](const EdgeCalibration& e) { return std::int64_t(e.pixels); });
    edges["rows"] = column([](const EdgeCalibration& e) { return std::int64_t(e.rows); });
    edges["residual_rms"] = column([](const EdgeCalibration& e) { return e.residual_rms; });
    edges["chi2"] = column([](const EdgeCalibration& e) { return e.chi2; });
    edges["redundancy"] = column([](const EdgeCalibration& e) { return e.redundancy; });
    edges["vce_scale"] = column([](const EdgeCalibration& e) { return e.vce_scale; });
    edges["correlation"] = column([](const EdgeCalibration& e) { return e.correlation; });
    edges["inflation"] = column([](const EdgeCalibration& e) { return e.inflation; });
    edges["effective_pixels"] = column([](const EdgeCalibration& e) { return e.effective_pixels; });
  }
  d["edges"] = edges;
  return d;
}

/// dba-covariance -o through its own sink (app::PoseRawlogSink: the same records, order and
/// file, written atomically through the MRPT bridge, which is loaded here on first use).
/// `times[c]` replaces the keyframe times of covariance c; else `fps` derives them as --fps does.
/// Errors name the snapshot as the CLI's error lines do.
/// dba-covariance's default sensorLabel for the noise model the covariances hold; InputError
/// when they mix the self-calibrated and the stated model (one label would misname some).
std::string defaultLabel(const std::vector<const PyCovariance*>& covs) {
  std::size_t calibrated = 0;
  for (const PyCovariance* c : covs) calibrated += c->calibration.has_value();
  if (calibrated != 0 && calibrated != covs.size())
    throw InputError(
        "the covariances mix the self-calibrated and the stated noise model: give label= to "
        "name the observations");
  app::CovarianceAppOptions o;
  o.self_calibration.stated_model = !covs.empty() && calibrated == 0;
  return o.rawlogLabel();
}

void writePoseRawlog(const std::string& path, const std::vector<const PyCovariance*>& covs,
                     const std::vector<std::optional<std::vector<double>>>& times,
                     const std::string& emit, const std::optional<std::string>& label,
                     std::optional<double> fps, double start_time) {
  python::checkPath(path, "path");
  if (covs.empty())  // an empty rawlog would replace whatever the path holds
    throw InputError(path + ": no covariances to write (the file is left as it is)");
  for (std::size_t c = 0; c < covs.size(); ++c)
    if (!covs[c])  // pybind11 turns None into a null pointer
      throw py::type_error("covariances[" + std::to_string(c) +
                           "] is None, expected a dbacov.Covariance");
  const auto mode = parseEnum<app::EmitMode>(emit);
  if (fps) checkFps(*fps, "fps");
  app::PoseRawlogSink sink(path, label ? *label : defaultLabel(covs), mode);
  for (std::size_t c = 0; c < covs.size(); ++c) {
    const PyCovariance& pc = *covs[c];
    const Snapshot* s = pc.snapshot.get();
    try {
      std::optional<Snapshot> timed;  // a copy only when the times change
      const bool replace = c < times.size() && times[c].has_value();
      if (replace || (fps && !s->timestamps_s)) {
        timed = *s;
        if (replace) {
          if (times[c]->size() != static_cast<std::size_t>(s->numKeyframes()))
            throw InputError("times has " + std::to_string(times[c]->size()) +
                             " values, the snapshot has " + std::to_string(s->numKeyframes()) +
                             " keyframes");
          timed->timestamps_s = *times[c];
        } else {
          deriveKeyframeTimes(*timed, *fps, start_time);
        }
      }
      const Snapshot& t = timed ? *timed : *s;
      sink.check(t);
      sink.verify(t, *pc.cov);
      sink.add(t, *pc.cov);
    } catch (const InputError& e) {
      throw InputError(s->name() + ": " + e.what());
    } catch (const std::domain_error& e) {
      throw std::domain_error(s->name() + ": " + e.what());
    }
  }
  sink.commit();
}

/// The keywords into DbaOptions by the one builder that dba-covariance's flags use
/// (DbaOptionOverrides::resolve): the same names, defaults and messages.
DbaOptions engineOptions(const std::string& preset, std::optional<double> weight_scale,
                         std::optional<std::string> gauge, std::optional<double> gauge_sigma_rot,
                         std::optional<double> gauge_sigma_trans, std::optional<double> near,
                         std::optional<double> far, std::optional<double> min_depth_ratio,
                         std::optional<double> sensor_depth_weight) {
  DbaOptionOverrides o;
  o.preset = parseEnum<Preset>(preset);
  o.weight_scale = weight_scale;
  if (gauge) o.gauge = parseEnum<GaugeOptions::Type>(*gauge);
  o.gauge_sigma_rot = gauge_sigma_rot;
  o.gauge_sigma_trans = gauge_sigma_trans;
  o.near = near;
  o.far = far;
  o.min_depth_ratio = min_depth_ratio;
  o.sensor_depth_weight = sensor_depth_weight;
  return o.resolve();
}

CovarianceOptions solverOptions(const std::string& solver, const std::string& ordering,
                                bool depth_sigma) {
  CovarianceOptions so;
  so.kind = parseEnum<SolverKind>(solver);
  so.ordering = parseEnum<Ordering>(ordering);
  so.depth_variances = depth_sigma;
  return so;
}

/// Covariance(...)'s keywords, resolved and checked (also without a snapshot: check_options).
struct CovarianceKeywords {
  DbaOptions engine;
  CovarianceOptions solver;
  SelfCalibrationAppOptions calibration;
};

CovarianceKeywords resolveKeywords(
    const std::string& preset, std::optional<double> weight_scale, std::optional<std::string> gauge,
    std::optional<double> gauge_sigma_rot, std::optional<double> gauge_sigma_trans,
    std::optional<double> near, std::optional<double> far, std::optional<double> min_depth_ratio,
    std::optional<double> sensor_depth_weight, const std::string& solver,
    const std::string& ordering, bool depth_sigma, bool stated_model,
    std::optional<int> self_calibrate_nodes, std::optional<bool> self_calibrate_depth_noise,
    bool converge, std::optional<int> converge_iterations) {
  CovarianceKeywords k;
  k.engine = engineOptions(preset, weight_scale, gauge, gauge_sigma_rot, gauge_sigma_trans, near,
                           far, min_depth_ratio, sensor_depth_weight);
  k.solver = solverOptions(solver, ordering, depth_sigma);
  k.calibration = selfCalibrationOptions(stated_model, self_calibrate_nodes,
                                         self_calibrate_depth_noise, converge, converge_iterations);
  return k;
}

void checkKeyframe(const PyCovariance& c, int k) {
  if (!c.cov->contains(k))
    throw py::key_error("keyframe " + std::to_string(k) +
                        " is not a graph keyframe of this snapshot (graph keyframes: " +
                        joinKeyframes(c.cov->keyframes()) + ")");
}

}  // namespace

PYBIND11_MODULE(_dbacov, m) {
  m.doc() = "dbacov: pose covariances from DROID-SLAM's dense bundle adjustment (C++ core)";
  static py::exception<InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<NumericalError> numerical_error(m, "NumericalError", PyExc_ArithmeticError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InputError& e) {
      input_error(e.what());
    } catch (const NumericalError& e) {
      numerical_error(e.what());
    }
  });

  py::class_<Snapshot, std::shared_ptr<Snapshot>>(m, "Snapshot")
      .def(py::init(&makeSnapshot), py::kw_only(), py::arg("poses"), py::arg("disps"),
           py::arg("intrinsics"), py::arg("ii"), py::arg("jj"), py::arg("target"),
           py::arg("weight"), py::arg("tstamp"), py::arg("timestamps_s") = py::none(),
           py::arg("id") = py::none(), py::arg("disps_sens") = py::none(),
           py::arg("stereo_rig") = py::none(), py::arg("t0") = py::none(),
           py::arg("source") = "<python>")
      .def_readonly("source", &Snapshot::source)
      .def_readonly("id", &Snapshot::id)
      .def_readonly("t0", &Snapshot::t0)
      .def_readonly("H", &Snapshot::H)
      .def_readonly("W", &Snapshot::W)
      .def_property_readonly("num_keyframes", &Snapshot::numKeyframes)
      .def_property_readonly("num_edges", &Snapshot::numEdges)
      .def_property_readonly("graph_keyframes", &Snapshot::graphKeyframes)
      .def_property_readonly("poses", [](const Snapshot& s) { return matrix(s.poses_cw); })
      .def_property_readonly(
          "tstamp", [](const Snapshot& s) { return py::array_t<double>(py::cast(s.tstamp)); })
      .def_property_readonly("timestamps_s",
                             [](const Snapshot& s) -> py::object {
                               if (!s.timestamps_s) return py::none();
                               return py::array_t<double>(py::cast(*s.timestamps_s));
                             })
      .def_property_readonly("is_stereo",
                             [](const Snapshot& s) { return s.stereo_rig.has_value(); })
      .def_property_readonly("is_rgbd", [](const Snapshot& s) { return s.disps_sens.has_value(); })
      .def(
          "save",
          [](const Snapshot& s, const std::string& path, bool compressed) {
            python::checkPath(path, "path");
            io::saveSnapshotNpz(path, s, compressed);
          },
          py::arg("path"), py::arg("compressed") = true, py::call_guard<py::gil_scoped_release>())
      .def("__repr__", [](const Snapshot& s) {
        return "<dbacov.Snapshot " + s.source + ": " + std::to_string(s.numKeyframes()) +
               " keyframes, " + std::to_string(s.numEdges()) + " edges, " + std::to_string(s.H) +
               "x" + std::to_string(s.W) + ">";
      });

  m.def(
      "load",
      [](const std::string& path) {
        python::checkPath(path, "path");
        return std::make_shared<Snapshot>(io::loadSnapshotNpz(path, 0));
      },
      py::arg("path"), py::call_guard<py::gil_scoped_release>(),
      "Reads one snapshot .npz (conventions §1); errors name the file and the key.");

  // For the call-overhead benchmark (tests/benchmarks/bench_python.py): seconds per iteration of
  // the same work as Covariance(snapshot) + marginals(), timed inside C++ (no Python involved).
  m.def(
      "_engine_seconds",
      [](std::shared_ptr<Snapshot> snap, int iterations) {
        const DbaOptions o = DbaOptions::droid();
        CovarianceOptions so;
        so.depth_variances = true;
        const auto t0 = std::chrono::steady_clock::now();
        double sink = 0;
        for (int it = 0; it < iterations; ++it) {
          const DbaCovariance cov(*snap, o, so);
          for (int k : cov.keyframes()) sink += cov.marginal(k)(0, 0);
        }
        const auto t1 = std::chrono::steady_clock::now();
        if (!(sink == sink)) throw std::logic_error("NaN");
        return std::chrono::duration<double>(t1 - t0).count() / iterations;
      },
      py::arg("snapshot"), py::arg("iterations"), py::call_guard<py::gil_scoped_release>());

  py::class_<PyCovariance> covariance(m, "Covariance");
  m.def(
      "_write_pose_rawlog",
      [](const std::string& path, const std::vector<const PyCovariance*>& covs,
         const std::string& emit, const std::optional<std::string>& label,
         std::optional<double> fps, double start_time) {
        py::gil_scoped_release release;
        writePoseRawlog(path, covs, {}, emit, label, fps, start_time);
      },
      py::arg("path"), py::arg("covariances"), py::kw_only(), py::arg("emit") = "latest",
      py::arg("label") = py::none(), py::arg("fps") = py::none(), py::arg("start_time") = 0.0);
  m.def("_mrpt_bridge_loaded", &mrpt_bridge::mrptBridgeLoaded);
  m.def(
      "check_options",
      [](const std::string& preset, std::optional<double> weight_scale,
         std::optional<std::string> gauge, std::optional<double> gauge_sigma_rot,
         std::optional<double> gauge_sigma_trans, std::optional<double> near,
         std::optional<double> far, std::optional<double> min_depth_ratio,
         std::optional<double> sensor_depth_weight, const std::string& solver,
         const std::string& ordering, std::size_t threads, bool depth_sigma, bool stated_model,
         std::optional<int> self_calibrate_nodes, std::optional<bool> self_calibrate_depth_noise,
         bool converge, std::optional<int> converge_iterations) {
        static_cast<void>(threads);
        resolveKeywords(preset, weight_scale, gauge, gauge_sigma_rot, gauge_sigma_trans, near, far,
                        min_depth_ratio, sensor_depth_weight, solver, ordering, depth_sigma,
                        stated_model, self_calibrate_nodes, self_calibrate_depth_noise, converge,
                        converge_iterations);
      },
      py::kw_only(), py::arg("preset") = "droid", py::arg("weight_scale") = py::none(),
      py::arg("gauge") = py::none(), py::arg("gauge_sigma_rot") = py::none(),
      py::arg("gauge_sigma_trans") = py::none(), py::arg("near") = py::none(),
      py::arg("far") = py::none(), py::arg("min_depth_ratio") = py::none(),
      py::arg("sensor_depth_weight") = py::none(), py::arg("solver") = "sparse",
      py::arg("ordering") = "auto", py::arg("threads") = 0, py::arg("depth_sigma") = true,
      py::arg("stated_model") = false, py::arg("self_calibrate_nodes") = py::none(),
      py::arg("self_calibrate_depth_noise") = py::none(), py::arg("converge") = false,
      py::arg("converge_iterations") = py::none(),
      "Checks Covariance's keywords without a snapshot (the same checks and messages): raises "
      "ValueError on a bad value, returns None");

  covariance
      .def(py::init([](std::shared_ptr<Snapshot> snap, const std::string& preset,
                       std::optional<double> weight_scale, std::optional<std::string> gauge,
                       std::optional<double> gauge_sigma_rot,
                       std::optional<double> gauge_sigma_trans, std::optional<double> near,
                       std::optional<double> far, std::optional<double> min_depth_ratio,
                       std::optional<double> sensor_depth_weight, const std::string& solver,
                       const std::string& ordering, std::size_t threads, bool depth_sigma,
                       bool stated_model, std::optional<int> self_calibrate_nodes,
                       std::optional<bool> self_calibrate_depth_noise, bool converge,
                       std::optional<int> converge_iterations) {
             if (!snap)  // pybind11 turns None into a null pointer
               throw py::type_error("snapshot is None, expected a dbacov.Snapshot or a path");
             auto c = std::make_unique<PyCovariance>();
             const CovarianceKeywords k = resolveKeywords(
                 preset, weight_scale, gauge, gauge_sigma_rot, gauge_sigma_trans, near, far,
                 min_depth_ratio, sensor_depth_weight, solver, ordering, depth_sigma, stated_model,
                 self_calibrate_nodes, self_calibrate_depth_noise, converge, converge_iterations);
             const SelfCalibrationAppOptions& sc = k.calibration;
             c->depth_sigma = depth_sigma;
             // Without the GIL, stopped by Ctrl-C between the engine's stages and loops.
             interruptible([&] {
               const ThreadLimit limit(threads);
               // dba-covariance's pipeline (computeCovariance); converge=True solves a copy: the
               // caller's snapshot is kept. The engine's numerical errors name no snapshot (their
               // callers do, as dba-covariance's "FILE (snapshot N): ..."): this one's name
               // first.
               try {
                 auto state = sc.converge ? std::make_shared<Snapshot>(*snap) : snap;
                 PipelineResult r = computeCovariance(*state, sc.pipeline(k.engine, k.solver));
                 c->snapshot = std::move(state);
                 c->cov = std::move(r.cov);
                 c->options = r.options;
                 c->calibration = std::move(r.calibration);
                 c->solve = r.solve;
                 c->reweighted = std::move(r.reweighted);
               } catch (const NumericalError& e) {
                 throw NumericalError(snap->name() + ": " + e.what(), e.keyframes());
               }
             });
             return c;
           }),
           py::arg("snapshot"), py::kw_only(), py::arg("preset") = "droid",
           py::arg("weight_scale") = py::none(), py::arg("gauge") = py::none(),
           py::arg("gauge_sigma_rot") = py::none(), py::arg("gauge_sigma_trans") = py::none(),
           py::arg("near") = py::none(), py::arg("far") = py::none(),
           py::arg("min_depth_ratio") = py::none(), py::arg("sensor_depth_weight") = py::none(),
           py::arg("solver") = "sparse", py::arg("ordering") = "auto", py::arg("threads") = 0,
           py::arg("depth_sigma") = true, py::arg("stated_model") = false,
           py::arg("self_calibrate_nodes") = py::none(),
           py::arg("self_calibrate_depth_noise") = py::none(), py::arg("converge") = false,
           py::arg("converge_iterations") = py::none())
      .def_property_readonly(
          "self_calibration",
          [](const PyCovariance& c) -> py::object {
            if (!c.calibration) return py::none();
            py::dict d = calibrationDict(*c.calibration);
            d["depth_noise"] = c.calibration->depth_noise;
            d["depth_noise_share"] = c.cov->summary().self_calibration.depth_noise_share;
            d["depth_noise_kurtosis"] = c.cov->summary().self_calibration.depth_noise_kurtosis;
            d["depth_noise_cross_kurtosis"] =
                c.cov->summary().self_calibration.depth_noise_cross_kurtosis;
            d["edge_scale_spread"] = c.cov->summary().self_calibration.edge_scale_spread;
            d["poor_fit"] = c.cov->summary().self_calibration.poor_fit;
            return std::move(d);
          })
      .def_property_readonly("reweighting",
                             [](const PyCovariance& c) -> py::object {
                               if (!c.reweighted) return py::none();
                               py::dict d;
                               d["solves"] = c.reweighted->solves;
                               d["settled"] = c.reweighted->settled;
                               d["last_ratio"] = c.reweighted->last_ratio;
                               d["unmeasured"] = c.reweighted->unmeasured;
                               // a re-solve that did not converge (the state is the last
                               // converged one): its summary, else None
                               d["failed_solve"] =
                                   c.reweighted->failed_solve
                                       ? py::object(py::str(c.reweighted->failed_solve->brief()))
                                       : py::object(py::none());
                               d["sensor_depth_factor"] = c.reweighted->sensor_depth_factor;
                               d["edge_factors"] = c.reweighted->edge_factors;
                               return std::move(d);
                             })
      .def_property_readonly("converged",
                             [](const PyCovariance& c) -> py::object {
                               if (!c.solve) return py::none();
                               return py::bool_(c.solve->converged());
                             })
      .def(
          "summary",
          [](const PyCovariance& c, bool full) {
            return full ? c.cov->summary().full() : c.cov->summary().brief();
          },
          py::arg("full") = false,
          "What the computation did (solver, ordering, nnz(L), pixels, time per stage, "
          "self-calibration): one line, or every field with full=True")
      .def(
          "write_pose_rawlog",
          [](const PyCovariance& c, const std::string& path, const std::string& emit,
             const std::optional<std::string>& label, std::optional<double> fps, double start_time,
             std::optional<std::vector<double>> times) {
            py::gil_scoped_release release;
            writePoseRawlog(path, {&c}, {times}, emit, label, fps, start_time);
          },
          py::arg("path"), py::kw_only(), py::arg("emit") = "latest", py::arg("label") = py::none(),
          py::arg("fps") = py::none(), py::arg("start_time") = 0.0, py::arg("times") = py::none(),
          "dba-covariance -o for this snapshot: a gz rawlog of CObservationRobotPose, written "
          "atomically through the MRPT bridge")
      .def_property_readonly("keyframes", [](const PyCovariance& c) { return c.cov->keyframes(); })
      .def_property_readonly("gauge_keyframes",
                             [](const PyCovariance& c) { return c.cov->gaugeKeyframes(); })
      .def_property_readonly("snapshot", [](const PyCovariance& c) { return c.snapshot; })
      .def("free_dof",
           [](const PyCovariance& c, int k) {
             checkKeyframe(c, k);
             return c.cov->freeDof(k);
           })
      .def(
          "marginal",
          [](const PyCovariance& c, int k) {
            checkKeyframe(c, k);
            Eigen::MatrixXd M;
            {
              py::gil_scoped_release release;
              M = c.cov->marginal(k);
            }
            return matrix(M);
          },
          py::arg("keyframe"),
          "6×6 covariance of the keyframe's tangent [rho; phi] (conventions §3)")
      .def(
          "joint",
          [](const PyCovariance& c, int a, int b) {
            checkKeyframe(c, a);
            checkKeyframe(c, b);
            Eigen::MatrixXd M;
            {
              py::gil_scoped_release release;
              M = c.cov->joint(a, b);
            }
            return matrix(M);
          },
          py::arg("a"), py::arg("b"), "12×12 joint covariance of (xi_a, xi_b)")
      .def(
          "relative",
          [](const PyCovariance& c, int a, int b) {
            checkKeyframe(c, a);
            checkKeyframe(c, b);
            Eigen::MatrixXd M;
            {
              py::gil_scoped_release release;
              M = c.cov->relative(a, b);
            }
            return matrix(M);
          },
          py::arg("a"), py::arg("b"), "6×6 covariance of the tangent of T_wc_a^-1 T_wc_b")
      .def("marginals",
           [](const PyCovariance& c) {
             const std::vector<int>& kf = c.cov->keyframes();
             py::array_t<double> out(
                 {static_cast<py::ssize_t>(kf.size()), py::ssize_t(6), py::ssize_t(6)});
             double* o = out.mutable_data();
             {
               py::gil_scoped_release release;
               for (std::size_t a = 0; a < kf.size(); ++a) {
                 const Matrix6d M = c.cov->marginal(kf[a]);
                 for (int i = 0; i < 6; ++i)
                   for (int j = 0; j < 6; ++j) o[(a * 6 + i) * 6 + j] = M(i, j);
               }
             }
             return out;
           })
      .def(
          "inverse_depth_sigma",
          [](const PyCovariance& c, int k) {
            checkKeyframe(c, k);
            if (!c.depth_sigma)
              throw std::invalid_argument(
                  "inverse_depth_sigma needs Covariance(..., depth_sigma=True)");
            std::vector<float> v;
            {
              py::gil_scoped_release release;
              v = c.cov->inverseDepthSigma(k);
            }
            py::array_t<float> out({c.snapshot->H, c.snapshot->W});
            std::copy(v.begin(), v.end(), out.mutable_data());
            return out;
          },
          py::arg("keyframe"),
          "(H,W) standard deviation of each pixel's inverse depth; NaN without information")
      .def_property_readonly("stats", [](const PyCovariance& c) {
        const LinearizationStats& s = c.cov->stats();
        py::dict d;
        d["factors_used"] = s.factors_used;
        d["factors_filtered"] = s.factors_filtered;
        d["depths_used"] = s.depths_used;
        d["depths_unobservable"] = s.depths_unobservable;
        d["chi2"] = s.chi2;
        return d;
      });
}
