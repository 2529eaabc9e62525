// PatchGraph <- .npz: every shape relation is checked here, values in PatchGraph::validate.
#include "dbacov/io/patch_graph_npz.h"

#include <climits>
#include <optional>

#include "dbacov/io/npz.h"

namespace dbacov::io {
namespace {

const std::vector<std::string> kRequired = {"poses", "patches", "intrinsics", "ii", "jj",
                                            "kk",    "target",  "weight",     "t0", "tstamp"};
const std::vector<std::string> kOptional = {"timestamps_s", "id", "is_global"};

/// The arrays of one archive by key, with messages that name the file and the key.
class Arrays {
 public:
  Arrays(std::string path, const NpzReader& npz) : path_(std::move(path)) {
    for (const std::string& key : kRequired)
      if (!npz.has(key))
        throw InputError(path_ + ": missing required key '" + key +
                         "' (a patch-graph snapshot, docs/reference/formats.md)");
    keys_ = kRequired;
    for (const std::string& key : kOptional)
      if (npz.has(key)) keys_.push_back(key);
    arrays_ = npz.readAll(keys_);  // the memory budget covers all of them together
  }

  std::string context(const std::string& key) const { return path_ + ": key '" + key + "'"; }
  const NpyArray* find(const std::string& key) const {
    for (std::size_t i = 0; i < keys_.size(); ++i)
      if (keys_[i] == key) return &arrays_[i];
    return nullptr;
  }
  const NpyArray& get(const std::string& key) const { return *find(key); }

  /// InputError unless the shape of `key` is `expected`; `why` says where the sizes come from.
  void expectShape(const std::string& key, const std::vector<std::size_t>& expected,
                   const std::string& pattern, const std::string& why = "") const {
    const NpyArray& a = get(key);
    if (a.shape == expected) return;
    throw InputError(context(key) + " has shape " + shapeToString(a.shape) + ", expected " +
                     (a.shape.size() == expected.size() ? shapeToString(expected) : pattern) +
                     (why.empty() ? "" : " (" + why + ")"));
  }
  /// One integer from a () or (1,) array of an integer dtype (bool/uint8 too when `flag`).
  std::int64_t scalar(const std::string& key, bool flag = false) const {
    const NpyArray& a = get(key);
    if (!a.shape.empty() && a.shape != std::vector<std::size_t>{1})
      throw InputError(context(key) + " has shape " + shapeToString(a.shape) +
                       ", expected () or (1,)");
    if (flag && (a.dtype == NpyArray::DType::UInt8 || a.dtype == NpyArray::DType::Bool))
      return a.data[0];
    return npyToInt64s(a, context(key)).at(0);
  }
  int dimension(const std::string& key, std::size_t d) const {
    if (d > static_cast<std::size_t>(INT_MAX / 8))
      throw InputError(context(key) + " has a dimension of " + std::to_string(d) +
                       ", more than supported");
    return static_cast<int>(d);
  }

 private:
  std::string path_;
  std::vector<std::string> keys_;
  std::vector<NpyArray> arrays_;
};

PatchGraph readPatchGraph(const std::string& path, const NpzReader& npz, std::int64_t index) {
  const Arrays a(path, npz);
  const NpyArray& poses = a.get("poses");
  const NpyArray& patches = a.get("patches");
  if (poses.shape.size() != 2) a.expectShape("poses", {0, 7}, "(N,7)");
  const std::size_t N = poses.shape[0];
  a.expectShape("poses", {N, 7}, "(N,7)");
  if (patches.shape.size() != 5)
    throw InputError(a.context("patches") + " has shape " + shapeToString(patches.shape) +
                     ", expected (N,M,3,P,P)");
  const std::size_t M = patches.shape[1], P = patches.shape[3];
  a.expectShape("patches", {N, M, 3, P, P}, "(N,M,3,P,P)", "N from 'poses'");
  if (P == 0) throw InputError(a.context("patches") + " has empty P×P patches");
  a.expectShape("intrinsics", {4}, "(4,)", "fx fy cx cy");
  if (a.get("ii").shape.size() != 1) a.expectShape("ii", {0}, "(E,)");
  const std::size_t E = a.get("ii").shape[0];
  for (const char* key : {"jj", "kk"}) a.expectShape(key, {E}, "(E,)", "E from 'ii'");
  for (const char* key : {"target", "weight"}) a.expectShape(key, {E, 2}, "(E,2)", "E from 'ii'");
  a.expectShape("tstamp", {N}, "(N,)", "N from 'poses'");
  if (a.find("timestamps_s")) a.expectShape("timestamps_s", {N}, "(N,)", "N from 'poses'");

  PatchGraph g;
  g.source = path;
  g.index = index;
  a.dimension("poses", N);
  a.dimension("ii", E);
  a.dimension("patches", N * M);
  g.M = static_cast<int>(M);
  const std::vector<double> pose_values = npyToDoubles(poses, a.context("poses"));
  g.poses_cw.resize(static_cast<Eigen::Index>(N), 7);
  std::copy(pose_values.begin(), pose_values.end(), g.poses_cw.data());  // both row-major
  // Only the centre of each patch enters DPVO's factor (formats.md).
  const std::vector<double> pv = npyToDoubles(patches, a.context("patches"));
  const std::size_t c = P / 2, plane = P * P, centre = c * P + c;
  g.patch_x.resize(N * M);
  g.patch_y.resize(N * M);
  g.patch_d.resize(N * M);
  for (std::size_t p = 0; p < N * M; ++p) {
    const double* base = &pv[p * 3 * plane + centre];
    g.patch_x[p] = base[0];
    g.patch_y[p] = base[plane];
    g.patch_d[p] = base[2 * plane];
  }
  const std::vector<double> k = npyToDoubles(a.get("intrinsics"), a.context("intrinsics"));
  g.intrinsics = Eigen::Vector4d(k[0], k[1], k[2], k[3]);
  g.ii = npyToInt64s(a.get("ii"), a.context("ii"));
  g.jj = npyToInt64s(a.get("jj"), a.context("jj"));
  g.kk = npyToInt64s(a.get("kk"), a.context("kk"));
  g.target = npyToDoubles(a.get("target"), a.context("target"));
  g.weight = npyToDoubles(a.get("weight"), a.context("weight"));
  g.t0 = a.scalar("t0");
  g.tstamp = npyToDoubles(a.get("tstamp"), a.context("tstamp"));
  if (a.find("timestamps_s"))
    g.timestamps_s = npyToDoubles(a.get("timestamps_s"), a.context("timestamps_s"));
  if (a.find("id")) g.id = a.scalar("id");
  if (a.find("is_global")) g.is_global = a.scalar("is_global", true) != 0;
  g.validate();
  return g;
}

}  // namespace

bool isPatchGraphNpz(const std::string& path) {
  const NpzReader npz(path);
  return npz.has("kk") && npz.has("patches");
}

PatchGraph loadPatchGraphNpz(const std::string& path, std::int64_t index) {
  return readPatchGraph(path, NpzReader(path), index);
}

PatchGraph loadPatchGraphNpzFromMemory(const std::string& name, std::vector<unsigned char> bytes,
                                       std::int64_t index) {
  return readPatchGraph(name, NpzReader::fromMemory(name, std::move(bytes)), index);
}

}  // namespace dbacov::io
