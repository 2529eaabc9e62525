// Snapshot <-> .npz (conventions §1): every shape relation is checked here, values in
// Snapshot::validate.
#include "dbacov/io/snapshot_npz.h"

#include <algorithm>
#include <climits>
#include <filesystem>
#include <optional>

#include "dbacov/io/npz.h"

namespace dbacov::io {
namespace {

/// Reads the keys of one archive and checks their shapes, with messages that name file and key.
class SnapshotReader {
 public:
  SnapshotReader(const std::string& path, NpzReader npz) : path_(path), npz_(std::move(npz)) {}

  std::string context(const std::string& key) const { return path_ + ": key '" + key + "'"; }

  void requireKey(const std::string& key) const {
    if (!npz_.has(key))
      throw InputError(path_ + ": missing required key '" + key + "' (conventions §1)");
  }
  bool hasKey(const std::string& key) const { return npz_.has(key); }
  std::vector<NpyArray> readAll(const std::vector<std::string>& keys) const {
    return npz_.readAll(keys);
  }

  /// Throws unless a.shape == expected. `pattern` is the symbolic shape ("(E,2,H,W)"), shown when
  /// even the number of dimensions is wrong; `why` says where the sizes come from.
  void expectShape(const std::string& key, const NpyArray& a,
                   const std::vector<std::size_t>& expected, const std::string& pattern,
                   const std::string& why = "") const {
    if (a.shape == expected) return;
    const std::string shown = a.shape.size() == expected.size() ? shapeToString(expected) : pattern;
    throw InputError(context(key) + " has shape " + shapeToString(a.shape) + ", expected " + shown +
                     (why.empty() ? "" : " (" + why + ")"));
  }
  /// Throws unless `a` has `ndim` dimensions; the message shows `pattern`.
  void expectNdim(const std::string& key, const NpyArray& a, std::size_t ndim,
                  const std::string& pattern) const {
    if (a.shape.size() != ndim)
      throw InputError(context(key) + " has shape " + shapeToString(a.shape) + ", expected " +
                       pattern);
  }
  /// A dimension that must fit the int counters of Snapshot.
  int dimension(const std::string& key, std::size_t d) const {
    if (d > static_cast<std::size_t>(INT_MAX))
      throw InputError(context(key) + " has a dimension of " + std::to_string(d) +
                       ", more than supported (" + std::to_string(INT_MAX) + ")");
    return static_cast<int>(d);
  }

 private:
  std::string path_;
  NpzReader npz_;
};

/// Reads and checks every key of the archive `npz` (conventions §1); `path` names it in messages.
Snapshot readSnapshot(const std::string& path, NpzReader npz, std::int64_t index) {
  const SnapshotReader r(path, std::move(npz));
  // Every member in one readAll (inflated in parallel); a missing required key is reported first,
  // in the order of the list, as reading them one by one did.
  std::vector<std::string> keys = {"poses", "disps",  "intrinsics", "ii",
                                   "jj",    "target", "weight",     "tstamp"};
  for (const std::string& key : keys) r.requireKey(key);
  // The optional keys: RGB-D (disps_sens), stereo (stereo_rig), DROID's gauge (t0), the times and
  // the label. Read with the others so that their sizes count against the same memory budget.
  const std::vector<std::string> optional_keys = {"timestamps_s", "id", "disps_sens", "stereo_rig",
                                                  "t0"};
  const std::size_t required = keys.size();
  for (const std::string& key : optional_keys)
    if (r.hasKey(key)) keys.push_back(key);
  std::vector<NpyArray> arrays = r.readAll(keys);
  const NpyArray poses = std::move(arrays[0]), disps = std::move(arrays[1]),
                 intrinsics = std::move(arrays[2]), ii = std::move(arrays[3]),
                 jj = std::move(arrays[4]), target = std::move(arrays[5]),
                 weight = std::move(arrays[6]), tstamp = std::move(arrays[7]);
  auto optional = [&](const std::string& key) -> std::optional<NpyArray> {
    for (std::size_t i = required; i < keys.size(); ++i)
      if (keys[i] == key) return std::move(arrays[i]);
    return std::nullopt;
  };
  const std::optional<NpyArray> timestamps_s = optional("timestamps_s"), id = optional("id"),
                                disps_sens = optional("disps_sens"),
                                stereo_rig = optional("stereo_rig"), t0 = optional("t0");

  // Shapes first (cheap, and the most useful message), then dtypes through the conversions.
  r.expectNdim("poses", poses, 2, "(N,7)");
  r.expectShape("poses", poses, {poses.shape[0], 7}, "(N,7)");
  const std::size_t N = poses.shape[0];
  r.expectNdim("disps", disps, 3, "(" + std::to_string(N) + ",H,W) (N from 'poses')");
  r.expectShape("disps", disps, {N, disps.shape[1], disps.shape[2]}, "(N,H,W)", "N from 'poses'");
  const std::size_t H = disps.shape[1], W = disps.shape[2];
  r.expectShape("intrinsics", intrinsics, {4}, "(4,)", "fx fy cx cy");
  r.expectNdim("ii", ii, 1, "(E,)");
  const std::size_t E = ii.shape[0];
  r.expectShape("jj", jj, {E}, "(E,)", "E from 'ii'");
  for (const auto& [key, a] :
       {std::pair<const char*, const NpyArray*>{"target", &target}, {"weight", &weight}})
    r.expectShape(key, *a, {E, 2, H, W}, "(E,2,H,W)", "E,2,H,W from 'ii' and 'disps'");
  r.expectShape("tstamp", tstamp, {N}, "(N,)", "N from 'poses'");
  if (timestamps_s) r.expectShape("timestamps_s", *timestamps_s, {N}, "(N,)", "N from 'poses'");
  for (const auto& [key, a] :
       {std::pair<const char*, const std::optional<NpyArray>*>{"id", &id}, {"t0", &t0}})
    if (*a && !(*a)->shape.empty() && (*a)->shape != std::vector<std::size_t>{1})
      throw InputError(r.context(key) + " has shape " + shapeToString((*a)->shape) +
                       ", expected () or (1,)");
  if (disps_sens)
    r.expectShape("disps_sens", *disps_sens, {N, H, W}, "(N,H,W)", "N,H,W from 'disps'");
  if (stereo_rig) r.expectShape("stereo_rig", *stereo_rig, {7}, "(7,)", "[tx ty tz qx qy qz qw]");

  Snapshot s;
  s.source = path;
  s.index = index;
  r.dimension("poses", N);
  r.dimension("ii", E);
  s.H = r.dimension("disps", H);
  s.W = r.dimension("disps", W);
  const std::vector<double> pose_values = npyToDoubles(poses, r.context("poses"));
  s.poses_cw.resize(static_cast<Eigen::Index>(N), 7);
  std::copy(pose_values.begin(), pose_values.end(), s.poses_cw.data());  // both row-major
  s.disps = npyToFloats(disps, r.context("disps"));
  const std::vector<double> k = npyToDoubles(intrinsics, r.context("intrinsics"));
  s.intrinsics = Eigen::Vector4d(k[0], k[1], k[2], k[3]);
  s.ii = npyToInt64s(ii, r.context("ii"));
  s.jj = npyToInt64s(jj, r.context("jj"));
  s.target = npyToFloats(target, r.context("target"));
  s.weight = npyToFloats(weight, r.context("weight"));
  s.tstamp = npyToDoubles(tstamp, r.context("tstamp"));
  if (timestamps_s) s.timestamps_s = npyToDoubles(*timestamps_s, r.context("timestamps_s"));
  if (id) s.id = npyToInt64s(*id, r.context("id")).at(0);
  if (disps_sens) s.disps_sens = npyToFloats(*disps_sens, r.context("disps_sens"));
  if (stereo_rig) {
    const std::vector<double> v = npyToDoubles(*stereo_rig, r.context("stereo_rig"));
    s.stereo_rig = Eigen::Map<const Eigen::Matrix<double, 7, 1>>(v.data());
  }
  if (t0) s.t0 = npyToInt64s(*t0, r.context("t0")).at(0);
  s.validate();
  return s;
}

}  // namespace

Snapshot loadSnapshotNpz(const std::string& path, std::int64_t index) {
  return readSnapshot(path, NpzReader(path), index);
}

std::optional<std::int64_t> readSnapshotId(const std::string& path) {
  const NpzReader npz(path);
  if (!npz.has("id")) return std::nullopt;
  const NpyArray id = npz.read("id");
  const std::string context = path + ": key 'id'";
  if (!id.shape.empty() && id.shape != std::vector<std::size_t>{1})
    throw InputError(context + " has shape " + shapeToString(id.shape) + ", expected () or (1,)");
  return npyToInt64s(id, context).at(0);
}

Snapshot loadSnapshotNpzFromMemory(const std::string& name, std::vector<unsigned char> bytes,
                                   std::int64_t index) {
  return readSnapshot(name, NpzReader::fromMemory(name, std::move(bytes)), index);
}

void saveSnapshotNpz(const std::string& path, const Snapshot& s, bool compressed) {
  s.validate();
  const std::size_t N = static_cast<std::size_t>(s.numKeyframes()),
                    E = static_cast<std::size_t>(s.numEdges()), H = static_cast<std::size_t>(s.H),
                    W = static_cast<std::size_t>(s.W);
  NpzWriter w(path, compressed);
  w.add("poses",
        makeNpy(std::vector<double>(s.poses_cw.data(), s.poses_cw.data() + N * 7), {N, 7}));
  w.add("disps", makeNpy(s.disps, {N, H, W}));
  std::vector<float> k(4);
  for (int i = 0; i < 4; ++i) k[i] = static_cast<float>(s.intrinsics[i]);
  w.add("intrinsics", makeNpy(k, {4}));
  w.add("ii", makeNpy(s.ii, {E}));
  w.add("jj", makeNpy(s.jj, {E}));
  w.add("target", makeNpy(s.target, {E, 2, H, W}));
  w.add("weight", makeNpy(s.weight, {E, 2, H, W}));
  w.add("tstamp", makeNpy(s.tstamp, {N}));
  if (s.timestamps_s) w.add("timestamps_s", makeNpy(*s.timestamps_s, {N}));
  if (s.id) w.add("id", makeNpy(std::vector<std::int64_t>{*s.id}, {}));
  if (s.disps_sens) w.add("disps_sens", makeNpy(*s.disps_sens, {N, H, W}));
  if (s.stereo_rig)
    w.add("stereo_rig",
          makeNpy(std::vector<double>(s.stereo_rig->data(), s.stereo_rig->data() + 7), {7}));
  if (s.t0) w.add("t0", makeNpy(std::vector<std::int64_t>{*s.t0}, {}));
  w.commit();
}

std::vector<std::string> listNpzFiles(const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    throw InputError(
        dir + ": cannot list .npz files: " + (ec ? ec.message() : std::string("not a directory")));
  std::vector<std::string> names;
  fs::directory_iterator it(dir, ec);
  for (; !ec && it != fs::directory_iterator(); it.increment(ec)) {
    const std::string name = it->path().filename().string();
    std::error_code type_ec;
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".npz") == 0 &&
        it->is_regular_file(type_ec))
      names.push_back(name);
  }
  if (ec) throw InputError(dir + ": cannot list .npz files: " + ec.message());
  std::sort(names.begin(), names.end());
  std::vector<std::string> paths;
  paths.reserve(names.size());
  for (const std::string& name : names) paths.push_back((fs::path(dir) / name).string());
  return paths;
}

}  // namespace dbacov::io
