// The Ceres peer as a whole process, for tests/benchmarks/bench_side_by_side.sh: what a
// user would run instead of dba-covariance. For every snapshot (.npz files, or a directory of
// them in name order): load it, build the full problem of ceres_problems.h (pose and inverse-depth
// blocks, one residual block per pixel factor, preset droid), ceres::Covariance (SPARSE_QR, one
// thread) for every free keyframe's 6×6 marginal, and write them as CSV rows
// `snapshot,keyframe,c00,c01,...,c55` (the full 6×6 in row order, %.17g).
//
//   build/bin/peer_ceres_covariance -i SNAPSHOTS [-i ...] --csv OUT.csv
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "ceres_problems.h"
#include "dbacov/io/snapshot_npz.h"

int main(int argc, char** argv) {
  using namespace dbacov;
  std::vector<std::string> inputs;
  std::string csv;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    if ((arg == "-i" || arg == "--csv") && a + 1 < argc) {
      (arg == "-i" ? inputs.emplace_back(argv[++a]) : csv = argv[++a]);
    } else {
      std::cerr << "usage: peer_ceres_covariance -i SNAPSHOTS [-i ...] --csv OUT.csv\n";
      return 2;
    }
  }
  if (inputs.empty() || csv.empty()) {
    std::cerr << "usage: peer_ceres_covariance -i SNAPSHOTS [-i ...] --csv OUT.csv\n";
    return 2;
  }
  std::vector<std::string> files;
  for (const std::string& in : inputs) {
    if (std::filesystem::is_directory(in)) {
      for (const std::string& f : io::listNpzFiles(in)) files.push_back(f);
    } else {
      files.push_back(in);
    }
  }
  std::FILE* out = std::fopen(csv.c_str(), "w");
  if (!out) {
    std::cerr << "peer_ceres_covariance: cannot write " << csv << "\n";
    return 1;
  }
  std::fprintf(out, "snapshot,keyframe");
  for (int r = 0; r < 6; ++r)
    for (int c = 0; c < 6; ++c) std::fprintf(out, ",c%d%d", r, c);
  std::fprintf(out, "\n");
  int failed = 0;
  for (std::size_t n = 0; n < files.size(); ++n) {
    try {
      const Snapshot s = io::loadSnapshotNpz(files[n], static_cast<std::int64_t>(n));
      const bench::CeresFullProblem cp = bench::buildCeresFullProblem(s, DbaOptions::droid());
      ceres::Covariance::Options opt;
      opt.algorithm_type = ceres::SPARSE_QR;
      opt.num_threads = 1;
      ceres::Covariance cov(opt);
      std::vector<std::pair<const double*, const double*>> pairs;
      for (int k : cp.free_keyframes) pairs.emplace_back(cp.xi.at(k).get(), cp.xi.at(k).get());
      if (!cov.Compute(pairs, cp.problem.get())) throw std::runtime_error("Compute failed");
      for (int k : cp.free_keyframes) {
        double b[36];
        cov.GetCovarianceBlock(cp.xi.at(k).get(), cp.xi.at(k).get(), b);
        std::fprintf(out, "%zu,%d", n, k);
        for (double v : b) std::fprintf(out, ",%.17g", v);
        std::fprintf(out, "\n");
      }
    } catch (const std::exception& e) {
      std::cerr << "peer_ceres_covariance: " << files[n] << ": " << e.what() << "\n";
      ++failed;
    }
  }
  if (std::fclose(out) != 0) return 1;
  return failed ? 1 : 0;
}
